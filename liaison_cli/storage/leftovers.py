"""What killed commands leave beside a result folder, and how the next command writing it settles them:
`.NAME.partial-PID-*` staging folders (storage.result_folders.staged_output) and `.NAME.old-PID-*` folders
holding a result set aside by an interrupted swap (storage.swap)."""

import os
import re
import shutil
import sys
from pathlib import Path

from liaison_cli.storage.atomic import fsync_folder
from liaison_cli.storage.locks import claim, pid_alive
from liaison_cli.storage.ownership import is_ours

# mkdtemp's random tail is 8 characters; our staging names put the writer's pid before it.
_STAGING_TAIL = re.compile(r"(?:(\d+)-)?[a-z0-9_]{8}")


def _staging_leftovers(path: Path) -> list[tuple[str, Path, int | None]]:
    """(kind, folder, writer pid or None) of each `.NAME.partial-*` / `.NAME.old-*` folder beside `path`."""
    try:
        entries = list(os.scandir(path.parent))
    except OSError:  # no parent yet, or unreadable: nothing to settle (writing will say what is wrong)
        return []
    found = []
    for entry in entries:
        for kind in ("partial", "old"):
            prefix = f".{path.name}.{kind}-"
            tail = _STAGING_TAIL.fullmatch(entry.name[len(prefix):]) if entry.name.startswith(prefix) else None
            if tail and entry.is_dir(follow_symlinks=False):
                found.append((kind, Path(entry.path), int(tail.group(1)) if tail.group(1) else None))
    return found


def recover_output(path) -> None:
    """Settle what killed commands left beside `path`, before a command writes it: a result set aside by an
    interrupted swap (`.NAME.old-*/NAME`) goes back to `path` if `path` is missing (one note on stderr), and
    is removed if `path` is there; a `.NAME.partial-*` staging folder is removed, and so is a `.NAME.lock` no
    process holds. Only folders that are ours
    (our marker or provenance, or empty) and that no live process uses (its pid is gone and its flock can be
    taken) are touched; nothing else is ever deleted."""
    path = Path(path)
    for kind, folder, pid in _staging_leftovers(path):
        if pid is not None and pid_alive(pid):
            continue
        with claim(folder) as held:
            if not held:
                continue
            if kind == "old":
                _settle_set_aside(folder, path)
            elif is_ours(folder) or not any(folder.iterdir()):
                shutil.rmtree(folder, ignore_errors=True)
    _remove_stale_writer_lock(path)


def _remove_stale_writer_lock(path: Path) -> None:
    """The `.NAME.lock` a killed writer left beside `path` (storage.locks.writer_lock removes its own when it lets
    go; a kill skips that): removed when no process holds it, as its holder would have."""
    import fcntl

    lock_path = path.parent / f".{path.name}.lock"
    try:
        handle = open(lock_path, "r")
    except OSError:
        return
    with handle:
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return  # held: a writer is at work
        try:
            if os.stat(lock_path).st_ino == os.fstat(handle.fileno()).st_ino:
                os.unlink(lock_path)
        except OSError:
            pass


def _settle_set_aside(aside: Path, path: Path) -> None:
    held = aside / path.name
    contents = os.listdir(aside)
    if contents not in ([], [path.name]) or (contents and not is_ours(held)):
        return  # not what swap_by_two_renames leaves: not ours to touch
    if contents and not os.path.lexists(path):
        os.replace(held, path)
        fsync_folder(path.parent)
        print(f"note: {path}: restored the previous result from {aside.name} (a replacement was interrupted "
              "between its two renames)", file=sys.stderr)
    shutil.rmtree(aside, ignore_errors=True)
