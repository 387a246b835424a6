"""Atomic file I/O, the one place that writes files: Parquet tables with provenance, text, bytes.

Every write goes to a temporary file in the destination folder, is fsynced, then renamed over the
target, so a reader sees the old file or the new one, never a torn one. pyarrow is imported only by the
functions that need it, so the numeric core can use the byte / text writers without loading it.
"""

import errno
import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

from liaison_cli.errors import OutputExistsError

METADATA_KEY = b"liaison"
RESULT_MARKER = ".liaison-result"  # in every folder liaison writes: only such folders are ever replaced


def _temp_beside(path: Path) -> str:
    """A temp file in the destination folder (so the rename is atomic) with normal permissions."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    return tmp


def _write_atomic(path, write) -> None:
    """Call write(temp_path), fsync, rename onto `path`; the temp file never survives a failure."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temp_beside(path)
    try:
        write(tmp)
        with open(tmp, "rb") as handle:
            os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes_atomic(data: bytes, path) -> None:
    _write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def write_text_atomic(text: str, path) -> None:
    _write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def write_parquet_atomic(df, path, metadata: dict) -> None:
    """Write a DataFrame with JSON metadata under the 'liaison' key."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    merged = dict(table.schema.metadata or {})
    merged[METADATA_KEY] = json.dumps(metadata, sort_keys=True).encode()
    table = table.replace_schema_metadata(merged)
    _write_atomic(path, lambda tmp: pq.write_table(table, tmp))


def read_metadata(path) -> dict:
    import pyarrow.parquet as pq

    return json.loads(pq.read_schema(path).metadata[METADATA_KEY])


def _is_ours(path: Path) -> bool:
    """A folder liaison wrote: its marker, a sweep manifest, or (results from before the marker) a Parquet
    table carrying liaison's provenance metadata."""
    if not path.is_dir():
        return False
    if (path / RESULT_MARKER).exists() or (path / "manifest.jsonl").exists():
        return True
    for table in path.glob("*.parquet"):
        try:
            read_metadata(table)
            return True
        except Exception:  # noqa: BLE001 - not readable as a liaison table: not evidence of ours
            continue
    return False


def _check_replaceable(path: Path, overwrite: bool) -> bool:
    """True if `path` holds something to replace. Refuses (one line, exit 2) a non-empty folder without
    --overwrite, and any file or folder liaison did not write even with it."""
    if not path.exists() and not path.is_symlink():
        return False
    if path.is_dir() and not any(path.iterdir()):
        return False
    if not overwrite:
        kind = "directory" if path.is_dir() else "a file, not a directory, and"
        raise OutputExistsError(
            f"{path}: output {kind} already exists and is not empty; pass --overwrite to replace it "
            "or --output to choose another"
        )
    if not _is_ours(path):
        raise OutputExistsError(
            f"{path}: not a liaison result (no {RESULT_MARKER} marker); --overwrite replaces only folders liaison "
            "wrote. Remove it yourself or choose --output"
        )
    return True


def prepare_output_dir(path, overwrite: bool) -> Path:
    """An empty output folder at `path` (replacing a previous liaison result only with `overwrite`)."""
    path = Path(path)
    if _check_replaceable(path, overwrite):
        shutil.rmtree(path)
    _make_parent(path)
    path.mkdir(exist_ok=True)
    (path / RESULT_MARKER).write_text("written by liaison\n", encoding="utf-8")
    return path


def _make_parent(path: Path) -> None:
    """mkdir -p of the parent, naming the component that is a file (ENOTDIR) instead of 'File exists'."""
    for ancestor in reversed(path.parents):
        if ancestor.exists() and not ancestor.is_dir():
            raise NotADirectoryError(errno.ENOTDIR, os.strerror(errno.ENOTDIR), str(ancestor))
    path.parent.mkdir(parents=True, exist_ok=True)


@contextmanager
def staged_output(path, overwrite: bool):
    """Yield a sibling temporary folder to write a result into; when the block completes, it takes the
    place of `path` (a previous liaison result there is swapped out, then removed). A failed or killed
    run leaves `path` as it was, and at most a hidden `.NAME.partial-*` folder beside it."""
    path = Path(path)
    replace = _check_replaceable(path, overwrite)
    _make_parent(path)
    stage = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-", dir=path.parent))
    try:
        yield stage
        (stage / RESULT_MARKER).write_text("written by liaison\n", encoding="utf-8")
        os.chmod(stage, 0o777 & ~_umask())
        if replace:
            old = Path(tempfile.mkdtemp(prefix=f".{path.name}.old-", dir=path.parent))
            os.replace(path, old / path.name)
            os.replace(stage, path)
            shutil.rmtree(old)
        else:
            os.replace(stage, path)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask
