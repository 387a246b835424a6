"""Atomic file I/O, the one place that writes files: Parquet tables with provenance, text, bytes.

Every write goes to a temporary file in the destination folder, is fsynced, then renamed over the
target, and the folder is fsynced after the rename (so a power loss cannot undo it): a reader sees the old
file or the new one, never a torn one. pyarrow is imported only by the functions that need it, so the
numeric core can use the byte / text writers without loading it.

Result folders are built in a hidden sibling `.NAME.partial-PID-*` (holding a flock on it and carrying our
marker from the start) and swapped in whole; see staged_output and recover_output for what a kill at any
moment leaves and how the next command that writes NAME settles it.
"""

import errno
import functools
import json
import os
import re
import shutil
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

from liaison_cli import interrupts
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
    import re

    found = re.search(r"\[errno (\d+)\]", text, re.IGNORECASE)
    return int(found.group(1)) if found else None


def _write_atomic(path, write) -> None:
    """Call write(temp_path), fsync, rename onto `path`; the temp file never survives a failure."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _temp_beside(path)
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
    _write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def write_text_atomic(text: str, path) -> None:
    _write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def write_parquet_atomic(df, path, metadata: dict) -> None:
    """Write a DataFrame with JSON metadata under the 'liaison' key."""
    import pyarrow as pa

    _write_table_atomic(pa.Table.from_pandas(df, preserve_index=False), path, metadata)


def write_columns_atomic(columns: dict, path, metadata: dict) -> None:
    """Write columns (name -> 1-D numpy array, see arrow_table) with JSON metadata, without pandas."""
    _write_table_atomic(arrow_table(columns), path, metadata)


def _write_table_atomic(table, path, metadata: dict) -> None:
    import pyarrow.parquet as pq

    merged = dict(table.schema.metadata or {})
    merged[METADATA_KEY] = json.dumps(metadata, sort_keys=True).encode()
    table = table.replace_schema_metadata(merged)
    _write_atomic(path, lambda tmp: pq.write_table(table, tmp))


def arrow_table(columns: dict):
    """A pyarrow Table from columns (name -> 1-D numpy array: numbers, bools, or objects holding strings and
    None), built from buffers. pa.array() and pa.table() import pandas (about 0.3 s) to ask whether their
    input is a pandas object; `liaison run` writes all its tables without paying for that."""
    import pyarrow as pa

    return pa.Table.from_arrays([arrow_array(values) for values in columns.values()], names=list(columns))


def arrow_array(values):
    """The pyarrow array of a 1-D numpy array (see arrow_table): strings as utf8 with None as null; NaN in a
    float column stays NaN, as pa.array(values) keeps it."""
    import numpy as np
    import pyarrow as pa

    values = np.asarray(values)
    n = len(values)
    if values.dtype == object:  # labels: few distinct values, each encoded once, then expanded in C++
        items = values.tolist()
        labels = list(dict.fromkeys(items))
        code_of = {label: code for code, label in enumerate(labels)}
        codes = np.fromiter(map(code_of.__getitem__, items), dtype=np.int32, count=n)
        encoded = [b"" if label is None else str(label).encode("utf-8") for label in labels]
        offsets = np.zeros(len(encoded) + 1, dtype=np.int32)
        offsets[1:] = np.cumsum([len(b) for b in encoded])
        dictionary = pa.Array.from_buffers(pa.string(), len(encoded),
                                           [None, pa.py_buffer(offsets), pa.py_buffer(b"".join(encoded))])
        validity, nulls = None, 0
        if None in code_of:
            present = codes != code_of[None]
            validity, nulls = pa.py_buffer(np.packbits(present, bitorder="little")), int(n - present.sum())
        indices = pa.Array.from_buffers(pa.int32(), n, [validity, pa.py_buffer(codes)], null_count=nulls)
        return pa.DictionaryArray.from_arrays(indices, dictionary).dictionary_decode()
    if values.dtype == bool:
        return pa.Array.from_buffers(pa.bool_(), n, [None, pa.py_buffer(np.packbits(values, bitorder="little"))])
    values = np.ascontiguousarray(values)
    return pa.Array.from_buffers(pa.from_numpy_dtype(values.dtype), n, [None, pa.py_buffer(values)])


class ParquetStream:
    """One Parquet table written as its rows arrive, so a campaign of any size holds only a buffer.

    `append` takes columns (name -> 1-D array, the same names and dtypes each time); up to `flush_rows`
    rows are buffered and written as one row group (`dictionary_columns`: those whose values repeat). The file is built under a temporary name beside
    `path`, fsynced and renamed onto it by `close()` (`abort()` drops it). With no rows at all it writes an
    empty table.
    """

    def __init__(self, path, metadata: dict, flush_rows: int = 200_000, dictionary_columns=()):
        self._dictionary_columns = set(dictionary_columns)
        self.path = Path(path)
        self._metadata = metadata
        self._flush_rows = flush_rows
        self._buffer: list[dict] = []
        self._buffered_rows = 0
        self._tmp: str | None = None
        self._writer = None

    def append(self, columns: dict) -> None:
        rows = len(next(iter(columns.values()))) if columns else 0
        if rows:
            self._buffer.append(columns)
            self._buffered_rows += rows
        if self._buffered_rows >= self._flush_rows:
            with naming(self.path):
                self._flush()

    def _flush(self) -> None:
        import numpy as np
        import pyarrow.parquet as pq

        if not self._buffer:
            return
        names = list(self._buffer[0])
        table = arrow_table({name: np.concatenate([part[name] for part in self._buffer]) for name in names})
        self._buffer, self._buffered_rows = [], 0
        if self._writer is None:
            table = table.replace_schema_metadata(
                {METADATA_KEY: json.dumps(self._metadata, sort_keys=True).encode()})
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._tmp = _temp_beside(self.path)
            # Dictionary encoding only where values repeat (labels, run, epoch): on the float columns it
            # costs more time than it saves space; zstd is both faster and smaller than the default here.
            self._writer = pq.ParquetWriter(self._tmp, table.schema, compression="zstd",
                                            use_dictionary=[n for n in names if n in self._dictionary_columns])
        else:
            table = table.cast(self._writer.schema)
        self._writer.write_table(table)

    def close(self) -> None:
        try:
            with naming(self.path):
                self._close()
        except BaseException:
            self.abort()
            raise

    def _close(self) -> None:
        self._flush()
        if self._writer is None:
            write_columns_atomic({}, self.path, self._metadata)
            return
        self._writer.close()
        with open(self._tmp, "rb") as handle:
            os.fsync(handle.fileno())
        os.replace(self._tmp, self.path)
        self._tmp = None
        fsync_folder(self.path.parent)

    def abort(self) -> None:
        if self._writer is not None:
            try:
                self._writer.close()
            except Exception:  # noqa: BLE001 - the file is dropped anyway
                pass
        if self._tmp is not None:
            Path(self._tmp).unlink(missing_ok=True)
        self._writer, self._tmp, self._buffer = None, None, []


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
    if path.is_dir() and all(entry.name == RESULT_MARKER for entry in path.iterdir()):
        return False  # empty, or only our marker (a job that failed before writing anything)
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
    recover_output(path)
    if _check_replaceable(path, overwrite):
        shutil.rmtree(path)
    _make_parent(path)
    path.mkdir(exist_ok=True)
    _mark_ours(path)
    return path


def _mark_ours(folder: Path) -> None:
    write_text_atomic("written by liaison\n", folder / RESULT_MARKER)


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
    run leaves `path` as it was, and at most a hidden `.NAME.partial-PID-*` folder beside it, which the next
    command writing `path` removes (recover_output)."""
    path = Path(path)
    recover_output(path)
    replace = _check_replaceable(path, overwrite)
    _make_parent(path)
    try:
        # The pid in the name and the flock held on the folder tell a later command it is in use.
        stage = Path(tempfile.mkdtemp(prefix=f".{path.name}.partial-{os.getpid()}-", dir=path.parent))
    except OSError as exc:  # read-only, no permission, full: say where the result was to go
        raise OSError(exc.errno, exc.strerror, str(path)) from exc
    try:
        with _claim(stage, wait=True):
            _mark_ours(stage)  # from the start, so a killed run's folder is known as ours and cleaned
            yield stage
            if interrupts.requested():  # Ctrl-C that compiled code swallowed: the old result stays
                raise KeyboardInterrupt
            os.chmod(stage, 0o777 & ~_umask())
            _swap_in(stage, path, replace)
            interrupts.result_written(path)
    except OSError as exc:
        shutil.rmtree(stage, ignore_errors=True)
        if exc.filename is not None and str(exc.filename).startswith(str(stage)):
            # Name the file as the user knows it; the staging folder is gone.
            destination = path / Path(exc.filename).relative_to(stage)
            raise OSError(exc.errno, exc.strerror, str(destination)) from exc
        raise
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise


def _swap_in(stage: Path, path: Path, replace: bool) -> None:
    """Put the complete folder `stage` at `path`. A previous result there is exchanged with it in one atomic
    step where the system can (Linux renameat2), so `path` is never missing; it ends up at the stage's name
    and is removed. Elsewhere it is moved aside first (_swap_by_two_renames)."""
    if not replace:
        if path.is_dir() and not path.is_symlink():  # empty, or only our marker (_check_replaceable): ours to drop
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
    with _claim(aside, wait=True):
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


@contextmanager
def _claim(folder: Path, wait: bool = False):
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


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, someone else's
        return True
    return True


def recover_output(path) -> None:
    """Settle what killed commands left beside `path`, before a command writes it: a result set aside by an
    interrupted swap (`.NAME.old-*/NAME`) goes back to `path` if `path` is missing (one note on stderr), and
    is removed if `path` is there; a `.NAME.partial-*` staging folder is removed. Only folders that are ours
    (our marker or provenance, or empty) and that no live process uses (its pid is gone and its flock can be
    taken) are touched; nothing else is ever deleted."""
    path = Path(path)
    for kind, folder, pid in _staging_leftovers(path):
        if pid is not None and _pid_alive(pid):
            continue
        with _claim(folder) as held:
            if not held:
                continue
            if kind == "old":
                _settle_set_aside(folder, path)
            elif _is_ours(folder) or not any(folder.iterdir()):
                shutil.rmtree(folder, ignore_errors=True)


def _settle_set_aside(aside: Path, path: Path) -> None:
    held = aside / path.name
    contents = os.listdir(aside)
    if contents not in ([], [path.name]) or (contents and not _is_ours(held)):
        return  # not what _swap_by_two_renames leaves: not ours to touch
    if contents and not os.path.lexists(path):
        os.replace(held, path)
        fsync_folder(path.parent)
        print(f"note: {path}: restored the previous result from {aside.name} (a replacement was interrupted "
              "between its two renames)", file=sys.stderr)
    shutil.rmtree(aside, ignore_errors=True)


@contextmanager
def resumable_output(path, overwrite: bool, key: str):
    """Yield the folder a resumable job (a sweep, whose manifest records what is done) writes into.

    Without `overwrite`, or with nothing to replace: `path` itself (an existing liaison folder is resumed;
    a non-empty folder that is not, refused). With `overwrite` of an existing liaison result: a hidden
    sibling `.NAME.replacing-KEY`, swapped in when the block completes and kept if it is interrupted, so the
    same command (same `key`) resumes it while the old result stays in place until then.
    """
    path = Path(path)
    recover_output(path)
    if not overwrite or not _check_replaceable(path, overwrite):
        if not (path / "manifest.jsonl").exists():
            prepare_output_dir(path, overwrite=False)
        yield path
        return
    stage = path.parent / f".{path.name}.replacing-{key}"
    if stage.exists() and not _is_ours(stage) and any(stage.iterdir()):
        raise OutputExistsError(f"{stage}: not a liaison folder; remove it yourself or choose --output")
    stage.mkdir(exist_ok=True)
    _mark_ours(stage)
    yield stage
    _swap_in(stage, path, replace=True)


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask
