"""Is a folder in use? An exclusive flock held on the folder itself by the process writing it, and the
writer's pid (in the staging folder's name) still alive; and one writer at a time per result folder
(writer_lock: a sweep holds it for its whole run, a command replacing the folder while it swaps the new one in)."""

import errno
import os
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def claim(folder: Path, wait: bool = False):
    """Hold an exclusive flock on `folder` (the folder itself: no lock file to move into the result).
    Yields True if held; False if another process holds it, or if it cannot be known (gone, or a file system
    without flock on folders, such as some NFS): a folder whose use cannot be ruled out is left alone."""
    import fcntl

    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError:
        yield False
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
            held = True
        except OSError:
            held = False
        yield held
    finally:
        os.close(fd)


def pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, someone else's
        return True
    return True


class FolderBusy(Exception):
    """Another liaison process holds the folder's writer lock (writer_lock)."""


@contextmanager
def writer_lock(out_dir: Path):
    """One writer at a time per result folder: an exclusive lock on `.<folder>.lock` beside it (outside the folder,
    so a replacement cannot remove it from under its holder). Raises FolderBusy, without waiting, when another
    process holds it. The lock file is removed by its holder before it lets go; a process that locked a file
    already removed (it opened it just before) finds another inode at the path and locks again."""
    import fcntl

    out_dir = Path(out_dir)
    # Keyed on the folder, not on how its path is spelled: through a symlink or `..` it is the same lock.
    try:
        real = out_dir.resolve()
    except RuntimeError:  # Python < 3.13 reports a symlink loop so, not as an OSError
        raise OSError(errno.ELOOP, os.strerror(errno.ELOOP), str(out_dir)) from None
    real.parent.mkdir(parents=True, exist_ok=True)
    lock_path = real.parent / f".{real.name}.lock"
    while True:
        handle = open(lock_path, "a")
        try:
            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            raise FolderBusy(str(out_dir)) from None
        try:  # the file locked is still the one at the path (a finishing holder removes it), else lock again
            if os.stat(lock_path).st_ino == os.fstat(handle.fileno()).st_ino:
                break
        except FileNotFoundError:
            pass
        handle.close()
    try:
        yield
    finally:
        try:  # removed while still held, so no lock file stays behind (issue 47)
            os.unlink(lock_path)
        except OSError:
            pass
        fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
        handle.close()
