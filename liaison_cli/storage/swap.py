"""The last step of writing a result folder: the complete staging folder takes the place of NAME. Where the
system can (Linux renameat2 with RENAME_EXCHANGE) the two names are exchanged in one atomic step, so NAME
is never missing; elsewhere the old result is moved aside first, and what a kill between the two renames
leaves is put back by storage.leftovers.recover_output."""

import errno
import functools
import os
import shutil
import sys
import tempfile
from pathlib import Path

from liaison_cli.storage.atomic import fsync_folder
from liaison_cli.storage.locks import claim
from liaison_cli.storage.ownership import RESULT_MARKER


def swap_in(stage: Path, path: Path, replace: bool) -> None:
    """Put the complete folder `stage` at `path`. A previous result there is exchanged with it in one atomic
    step where the system can (Linux renameat2), so `path` is never missing; it ends up at the stage's name
    and is removed. Elsewhere it is moved aside first (_swap_by_two_renames)."""
    if not replace:
        if path.is_dir() and not path.is_symlink():  # empty, or only our marker (check_replaceable): ours to drop
            (path / RESULT_MARKER).unlink(missing_ok=True)
            path.rmdir()
        os.replace(stage, path)
        fsync_folder(path.parent)
        return
    if not _exchange(stage, path):
        _swap_by_two_renames(stage, path)
        return
    fsync_folder(path.parent)
    # A kill or a failure here leaves the old result under the stage's hidden name: cleaned next time.
    if stage.is_symlink():  # `path` was a symlink to a result: the link is what was replaced
        stage.unlink()
    else:
        shutil.rmtree(stage, ignore_errors=True)


def _swap_by_two_renames(stage: Path, path: Path) -> None:
    """The old result goes aside into `.NAME.old-PID-*/NAME`, then the stage takes its place. A failure
    between the two renames puts the old result back at once; a kill there leaves it aside, and the next
    command writing `path` puts it back (recover_output)."""
    aside = Path(tempfile.mkdtemp(prefix=f".{path.name}.old-{os.getpid()}-", dir=path.parent))
    with claim(aside, wait=True):
        try:
            os.replace(path, aside / path.name)
        except BaseException:
            aside.rmdir()
            raise
        try:
            os.replace(stage, path)
        except BaseException:
            os.replace(aside / path.name, path)
            fsync_folder(path.parent)
            aside.rmdir()
            raise
        fsync_folder(path.parent)
        shutil.rmtree(aside, ignore_errors=True)  # what a failure leaves here is cleaned next time


_RENAME_EXCHANGE = 2  # linux/fs.h
_AT_FDCWD = -100


@functools.cache
def _renameat2():
    """libc's renameat2, or None (not Linux, or a libc older than glibc 2.28)."""
    if not sys.platform.startswith("linux"):
        return None
    import ctypes

    try:
        function = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return None
    function.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    function.restype = ctypes.c_int
    return function


def _exchange(first: Path, second: Path) -> bool:
    """Swap two names atomically; False where the kernel or the file system cannot (the caller falls back)."""
    import ctypes

    renameat2 = _renameat2()
    if renameat2 is None:
        return False
    if renameat2(_AT_FDCWD, os.fsencode(first), _AT_FDCWD, os.fsencode(second), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EPERM):
        return False  # not supported here (old kernel, overlayfs on some kernels, FUSE, NFS ...)
    raise OSError(code, os.strerror(code), str(second))
