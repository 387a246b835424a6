"""Atomic writes of one file: a temporary file in the destination folder, fsynced, renamed over the target,
then the folder fsynced (so a power loss cannot undo the rename). A reader sees the old file or the new
one, never a torn one. Also the helpers every writer shares: `fsync_folder`, `naming` (an OSError that
names its file) and `current_umask`."""

import errno
import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path


def current_umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def temp_beside(path: Path) -> str:
    """A temp file in the destination folder (so the rename is atomic) with normal permissions."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, 0o666 & ~current_umask())
    return tmp


def fsync_folder(folder) -> None:
    """Make renames and new names in `folder` durable: the rename of a file is in the folder's own data, which
    an fsync of the file does not write (ext4, xfs may otherwise lose it in a power cut)."""
    fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(fd)
    except OSError as exc:
        if exc.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EBADF):  # cannot sync a folder: nothing to do
            raise OSError(exc.errno, exc.strerror, str(folder)) from exc
    finally:
        os.close(fd)


@contextmanager
def naming(path):
    """Re-raise an OSError that does not say which file it is about (pyarrow's do not) with `path` named,
    so the CLI's one line names the path and the cause."""
    try:
        yield
    except OSError as exc:
        if exc.filename is not None:
            raise
        code = exc.errno if exc.errno is not None else _errno_in_text(str(exc))
        cause = os.strerror(code) if code is not None else str(exc)
        raise OSError(code, cause, str(path)) from exc


def _errno_in_text(text: str) -> int | None:
    """pyarrow puts the errno in its message ('... [errno 28] No space left on device')."""
    found = re.search(r"\[errno (\d+)\]", text, re.IGNORECASE)
    return int(found.group(1)) if found else None


def write_atomic(path, write) -> None:
    """Call write(temp_path), fsync, rename onto `path`; the temp file never survives a failure."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_beside(path)
    try:
        with naming(path):
            write(tmp)
            with open(tmp, "rb") as handle:
                os.fsync(handle.fileno())
            os.replace(tmp, path)
            fsync_folder(path.parent)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes_atomic(data: bytes, path) -> None:
    write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def write_text_atomic(text: str, path) -> None:
    write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
