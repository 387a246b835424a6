"""Is a folder in use? An exclusive flock held on the folder itself by the process writing it, and the
writer's pid (in the staging folder's name) still alive."""

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
