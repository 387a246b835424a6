"""A sweep's manifest and its lock: a JSON-lines file (one header line, then one line per finished task) that is
the single source of truth of what is done, so a killed sweep started again with the same command skips
every task already in it.

A task whose line says 'error' (an exception in the worker: no result) is run again on resume and its new
line appended; the last line of a task wins. 'diverged' is a result (the filter's health check tripped) and
is kept.

Manifest format (the header's "format", plan.MANIFEST_FORMAT), and the migration rule:
- 2 (this version): a task may have several lines (a retried error); the last one counts.
- 1 (liaison before issue 24): the same header and record fields, each task once. Read as is and resumed
  in place: its header line is kept and new lines are appended as format 2, which a format-1 reader also
  reads (it too keeps the last line of a task).
A format newer than MANIFEST_FORMAT, or a header without one, is refused in one line (exit 2) naming the
file, and the file is left untouched. A new format must state here how each older one is read.
"""

import json
import os
from contextlib import contextmanager
from pathlib import Path

from liaison_cli import __version__
from liaison_cli.campaign.sweep.plan import MANIFEST_FORMAT, SweepError
from liaison_cli.storage import fsync_folder, naming
from liaison_cli.storage.locks import FolderBusy, writer_lock

READABLE_MANIFEST_FORMATS = (1, 2)  # see the module docstring: older formats are read and resumed in place


@contextmanager
def sweep_lock(out_dir: Path):
    """One sweep at a time per folder (storage.locks.writer_lock, which a command replacing the folder takes
    too): a busy folder is one line, exit 2."""
    try:
        with writer_lock(out_dir):
            yield
    except FolderBusy:
        raise SweepError(f"{out_dir}: another liaison sweep is writing into this folder; wait for it to "
                         "finish or choose --output") from None


def read_manifest(path: Path) -> tuple[dict | None, dict, int]:
    """(header, {task_id: record}, byte length of the valid prefix). A torn last line (killed mid-write)
    is ignored and later truncated away."""
    if not path.exists():
        return None, {}, 0
    data = path.read_bytes()
    header, records, valid = None, {}, 0
    position = 0
    for line in data.splitlines(keepends=True):
        position += len(line)
        if not line.endswith(b"\n"):
            break  # torn last line (killed mid-write): cut away on the next open
        try:
            entry = json.loads(line)
        except json.JSONDecodeError:
            if header is None:
                break
            valid = position
            continue  # a corrupt complete line is skipped, not the records after it (its task is recomputed)
        if header is None:
            header = entry
        elif isinstance(entry, dict) and "task" in entry:
            records[entry["task"]] = entry
        valid = position
    return header, records, valid


class Manifest:
    """Append-only JSON lines: flushed and fsynced after every finished batch."""

    def __init__(self, path: Path, header: dict):
        self.path = path
        existing, self.records, valid = read_manifest(path)
        if existing is not None:
            _check_header(path, existing, header)  # before the file is opened for writing: refused, untouched
        self.handle = open(path, "ab")
        self.handle.truncate(valid)
        if existing is None:
            self._write([header])
            fsync_folder(path.parent)  # the new file's name, not only its bytes

    def _write(self, entries):
        with naming(self.path):  # a full disk here names the manifest; a torn last line is dropped on resume
            self.handle.write(b"".join(json.dumps(e, sort_keys=True).encode() + b"\n" for e in entries))
            self.handle.flush()
            os.fsync(self.handle.fileno())

    def append(self, records: list[dict]) -> None:
        self._write(records)
        for record in records:
            self.records[record["task"]] = record

    def close(self):
        with naming(self.path):
            self.handle.close()

    def done(self) -> set[str]:
        """Tasks with a result: every recorded task but those whose last line is an 'error' (run again)."""
        return done_tasks(self.records)

    def done_on_disk(self) -> set[str]:
        """done() as the file holds it: a Ctrl-C that lands after a batch's bytes are written but before
        `records` is updated must still count that batch (the count is what a resume will find)."""
        return done_tasks(read_manifest(self.path)[1])


def done_tasks(records: dict) -> set[str]:
    """The tasks of {task_id: record} with a result (an 'error' record's task is run again)."""
    return {task for task, record in records.items() if record.get("status") != "error"}


def _check_header(path: Path, old, new: dict) -> None:
    """The manifest at `path` can be resumed by the sweep whose header is `new` (see the format rule)."""
    version = old.get("format") if isinstance(old, dict) else None
    if isinstance(version, int) and not isinstance(version, bool) and version > MANIFEST_FORMAT:
        raise SweepError(f"{path}: manifest format {version} is newer than this liaison ({__version__}) reads "
                         f"(up to {MANIFEST_FORMAT}); resume it with the liaison that wrote it, or pass --overwrite "
                         "to start again or --output to choose another folder")
    if version not in READABLE_MANIFEST_FORMATS or old.get("kind") != "header":
        raise SweepError(_header_mismatch(path, old, new))
    if {**old, "format": new["format"]} != new:
        raise SweepError(_header_mismatch(path, old, new))


def _header_mismatch(path, old, new) -> str:
    if not isinstance(old, dict) or old.get("format") not in READABLE_MANIFEST_FORMATS or old.get("kind") != "header":
        what = "a manifest this version cannot read"
    elif old.get("core_hash") != new["core_hash"]:
        what = "results of a different numeric core (liaison was changed or upgraded since)"
    elif old.get("sweep") != new["sweep"]:
        what = f"sweep {old.get('sweep')!r}"
    else:
        what = "a sweep over other scenarios or grid points"
    return (f"{path}: the folder holds {what}; resume needs the same scenarios and grid. "
            "Pass --overwrite to start again or --output to choose another folder")
