"""Which folders are liaison's: the marker file every result folder carries from its start, and the rule
for replacing an existing output (a non-empty folder only with --overwrite, and never one liaison did not
write)."""

from pathlib import Path

from liaison_cli.errors import OutputExistsError
from liaison_cli.storage.atomic import write_text_atomic
from liaison_cli.storage.parquet import read_metadata

RESULT_MARKER = ".liaison-result"  # in every folder liaison writes: only such folders are ever replaced
MANIFEST_HEADER_LIMIT = 64 * 2**20  # a sweep header lists its points: 10,000 points fit


def mark_ours(folder: Path) -> None:
    write_text_atomic("written by liaison\n", folder / RESULT_MARKER)


def is_ours(path: Path) -> bool:
    """A folder liaison wrote: its marker; or, for results from before the marker, a sweep manifest whose header
    is liaison's or a Parquet table carrying liaison's provenance metadata. A file name alone proves nothing:
    a user's folder may hold a `manifest.jsonl` of its own (issue 35: --overwrite deleted such a folder)."""
    if not path.is_dir():
        return False
    if (path / RESULT_MARKER).exists() or _liaison_manifest(path / "manifest.jsonl"):
        return True
    for table in path.glob("*.parquet"):
        try:
            read_metadata(table)
            return True
        except Exception:  # noqa: BLE001 - not readable as a liaison table: not evidence of ours
            continue
    return False


def _liaison_manifest(path: Path) -> bool:
    """The file's first line is a liaison sweep manifest's header (campaign.sweep.plan.SweepPlan.header): a JSON
    object of kind 'header' with a format number, the sweep's name, the code hash and its points."""
    import json

    try:
        with open(path, encoding="utf-8") as handle:
            header = json.loads(handle.readline(MANIFEST_HEADER_LIMIT))
    except (OSError, ValueError):
        return False
    return (isinstance(header, dict) and header.get("kind") == "header" and isinstance(header.get("format"), int)
            and {"sweep", "core_hash", "points"} <= set(header) and isinstance(header["points"], list))


def check_replaceable(path: Path, overwrite: bool) -> bool:
    """True if `path` holds something to replace. Refuses (one line, exit 2) a non-empty folder without
    --overwrite, and any file or folder liaison did not write even with it."""
    if not path.exists() and not path.is_symlink():
        return False
    if path.is_dir() and all(entry.name == RESULT_MARKER for entry in path.iterdir()):
        return False  # empty, or only our marker (a job that failed before writing anything)
    if not overwrite:
        kind = "directory" if path.is_dir() else "a file, not a directory, and"
        raise OutputExistsError(
            f"{path}: output {kind} already exists and is not empty; pass --overwrite to replace it "
            "or --output to choose another"
        )
    if not is_ours(path):
        raise OutputExistsError(
            f"{path}: not a liaison result (no {RESULT_MARKER} marker); --overwrite replaces only folders liaison "
            "wrote. Remove it yourself or choose --output"
        )
    return True
