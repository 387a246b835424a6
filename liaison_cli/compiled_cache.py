"""numba's on-disk cache of liaison's compiled kernels: one compile target, a folder keyed on the code, and
entries that heal.

- **Compile target.** The kernels are compiled for a generic x86-64 (or the architecture's generic) CPU
  (`NUMBA_CPU_NAME=generic`, set in the package root before numba is imported, unless the user set it), so
  a cache entry's key names no host CPU: a cache built on CI, in an image or on a colleague's machine serves
  every machine of the same architecture. Measured to cost no run time (docs/performance.md).
- **Locator.** numba files a function's cache under a hash of its source folder's absolute path, so a second
  checkout, a wheel in another environment or a copied cache missed every entry. `PackageLocator` files it
  under the module's folder inside the package, in `NUMBA_CACHE_DIR` (the package root sets that to
  `user_cache_dir()/numba-<hash of the compiled code>`), and stamps it with the module's code digest (its
  syntax tree without docstrings: liaison_cli.code_digest, as the folder's hash), not its modification
  time. A folder that cannot be written is still read (a cache shipped read-only in an image); nothing is
  saved there, and no other locator (one keyed on a single file, blind to the callees) takes a package file.
- **Healing.** A damaged entry (a truncated or foreign index or data file, as an interrupted copy leaves)
  made every later run fail with numba's UnpicklingError traceback. Now such an entry (an error that says the
  bytes are not a cache entry; an OS error is a miss and deletes nothing) is removed with one line on stderr,
  compiled again and saved. A loaded entry built for another signature is a miss.
- **Saves in turn.** numba reads an index, adds its entry and writes it back with no lock: two processes
  saving one function at once (test workers, warm-up's processes) could lose an entry or point one signature
  at the other's data file. A save holds an exclusive lock on the index's `.lock` file.
- **Compiles in turn.** Two processes that miss one function at once (warm-up's processes, test workers, pool
  workers on a cold cache) compiled it side by side, the same seconds twice. A process that misses a function
  now holds an exclusive lock on its `<index>.compiling` file until it has saved it; another that misses it
  meanwhile waits (at most COMPILE_WAIT_S), then loads what the first saved (or, for another signature,
  compiles its own). Locks follow calls (a caller's is held while its callees are compiled), and calls do not
  form cycles, so no two processes wait on each other; a process that dies releases its locks with it, a forked
  child holds none of its parent's, and a compile that fails releases its lock at once. Where the folder cannot
  be locked (no fcntl, a file system without flock, a lock file that cannot be made) the function is compiled
  as numba would, side by side. Left open: a Ctrl-C in the few statements between numba's load and its compile
  event, or between that event and its save, keeps the lock until the process leaves (a CLI process leaves on
  Ctrl-C; another process waits for it at most COMPILE_WAIT_S).

`install()` is called by each package that compiles (dynamics, measurements, estimation, analysis) before its
first `@njit(cache=True)`: numba picks a function's locator when the decorator runs.
"""

import os
import pickle
import sys
import time
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path

PACKAGE_ROOT = Path(__file__).resolve().parent
DAMAGED_NOTICE = "liaison: a damaged compiled-code cache entry was removed and is compiled again"
COMPILE_WAIT_S = 600.0  # the longest a process waits for another's compile of a function before compiling it too
COMPILE_POLL_S = 0.05
_installed = False
_compiling: dict[str, list] = {}  # this process's held compile locks: path -> [open file, depth]


def _package_folder(py_file: str) -> tuple[str, ...] | None:
    """The parts of py_file's folder below the package root, or None for a file outside the package."""
    try:
        return Path(py_file).resolve().parent.relative_to(PACKAGE_ROOT).parts
    except (OSError, ValueError):
        return None


@lru_cache(maxsize=None)
def _code_digest(path: str, mtime_ns: int, size: int) -> str:
    """code_digest of the file, through the package's memo (core_source_hash filled it at import)."""
    with open(path, "rb") as handle:
        return _memo().code_digest(handle.read())


@lru_cache(maxsize=1)
def _memo():
    from liaison_cli import _DigestMemo

    return _DigestMemo()


def _file_digest(path: str) -> str:
    """The module's code digest (docstrings and comments do not count: the folder's hash ignores them too)."""
    stat = os.stat(path)
    return _code_digest(path, stat.st_mtime_ns, stat.st_size)


# Errors that say a cache file's bytes are not a cache entry (truncated, foreign, another format).
DAMAGE = (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, ImportError, IndexError,
          KeyError)


def install() -> None:
    """Put PackageLocator first in numba's locator list and make the cache heal damaged entries (once)."""
    global _installed
    if _installed:
        return
    from numba.core import caching, config

    class PackageLocator(caching._CacheLocator):
        """A liaison module's cache folder: NUMBA_CACHE_DIR / liaison_cli / the module's folder in the package;
        freshness: the module's code digest (_file_digest). Not for files outside the package."""

        def __init__(self, py_func, py_file, folder):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = os.path.join(config.CACHE_DIR, PACKAGE_ROOT.name, *folder)

        def get_cache_path(self):
            return self._cache_path

        def get_source_stamp(self):
            return _file_digest(self._py_file)

        def get_disambiguator(self):
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func, py_file):
            folder = _package_folder(py_file)
            if not config.CACHE_DIR or folder is None:
                return None
            locator = cls(py_func, py_file, folder)
            try:
                locator.ensure_cache_path()
            except OSError:  # read-only (or missing and not creatable): read what is there, save nothing
                pass
            return locator

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    impl._locator_classes = [PackageLocator, *impl._locator_classes]
    _heal_damaged_entries(caching.Cache, PackageLocator)
    _release_after_failed_compiles(PackageLocator)
    _installed = True


def _heal_damaged_entries(cache_class, locator_class) -> None:
    """Wrap numba's Cache.load_overload / save_overload for liaison's functions (other packages' caches behave as
    numba made them): a damaged entry (DAMAGE) is removed, said in one line, and reported as a miss, so numba
    compiles it again and saves a sound entry; a loaded entry of another signature is a miss; a save holds the
    index's lock, first removes a damaged index it would merge into, and fails quietly where the folder cannot
    be written (the run goes on with its code in memory)."""
    load, save = cache_class.load_overload, cache_class.save_overload

    def ours(cache) -> bool:
        return isinstance(getattr(cache._impl, "locator", None), locator_class)

    def load_one(self, sig, target_context):
        try:
            result = load(self, sig, target_context)
        except DAMAGE as exc:
            _discard_index(self, exc)
            return None
        except OSError:  # unreadable now (permissions, a network file system): a miss, nothing deleted
            return None
        signature = getattr(result, "signature", None)
        if result is not None and signature is not None and tuple(signature.args) != tuple(sig):
            return None  # an index that points this signature at another's data: compile it
        return result

    def load_overload(self, sig, target_context):
        if not ours(self):
            return load(self, sig, target_context)
        result = load_one(self, sig, target_context)
        if result is None and _acquire_compile_lock(self):
            try:
                result = load_one(self, sig, target_context)  # saved by the process we waited for, if any
            except BaseException:  # Ctrl-C while it loads: no compile follows to release the lock
                _release_compile_lock(self)
                raise
            if result is not None:
                _release_compile_lock(self)
        return result  # a miss: numba compiles it now, and save_overload releases the lock

    cache_class.probe_overload = load_one  # a load that takes no lock (warm-up's read-back: no compile follows)

    def save_overload(self, sig, data):
        if not ours(self):
            return save(self, sig, data)
        try:
            with _index_lock(self):
                try:
                    self._cache_file._load_index()
                except DAMAGE as exc:
                    _discard_index(self, exc)
                save(self, sig, data)  # numba's own errors (an interrupted compile) stay numba's
        except OSError:
            pass  # a folder that cannot be written: nothing cached, the compiled code serves this process
        finally:
            _release_compile_lock(self)

    cache_class.load_overload, cache_class.save_overload = load_overload, save_overload


def _compile_lock_path(cache) -> str:
    return f"{cache._cache_file._index_path}.compiling"


def _acquire_compile_lock(cache) -> bool:
    """Hold the function's compile lock (module docstring, "Compiles in turn"), waiting while another process
    holds it; again in a process that holds it already (a second signature compiled while the first is): one
    more depth. False, and no lock, where there is no lock to take (no fcntl, a folder that cannot be written)
    or after COMPILE_WAIT_S: the function is then compiled as numba would."""
    try:
        import fcntl
    except ImportError:
        return False
    path = _compile_lock_path(cache)
    if path in _compiling:
        _compiling[path][1] += 1
        return True
    try:  # read-only suffices for flock: a shared cache another user filled can still be locked
        os.makedirs(cache._cache_path, exist_ok=True)
        handle = os.open(path, os.O_RDONLY | os.O_CREAT, 0o666)
    except OSError:
        return False
    deadline = time.monotonic() + COMPILE_WAIT_S
    while True:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            break
        except BlockingIOError:  # another process compiles it: wait for its save
            if time.monotonic() > deadline:
                os.close(handle)
                return False
            time.sleep(COMPILE_POLL_S)
        except OSError:
            os.close(handle)
            return False
    _compiling[path] = [handle, 1]
    return True


def _release_compile_lock(cache) -> None:
    """One depth of the function's compile lock, if this process holds it; the lock itself at the last."""
    held = _compiling.get(_compile_lock_path(cache))
    if held is None:
        return
    held[1] -= 1
    if held[1] == 0:
        del _compiling[_compile_lock_path(cache)]
        os.close(held[0])  # closing the file releases its flock


def _forget_inherited_locks() -> None:
    """In a forked child: the parent's compile locks are the parent's (a flock belongs to the open file, which the
    child shares); the child closes its copies and holds none."""
    for handle, _ in _compiling.values():
        try:
            os.close(handle)
        except OSError:
            pass
    _compiling.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_inherited_locks)


def _release_after_failed_compiles(locator_class) -> None:
    """A compile that raises (a typing error, Ctrl-C) never reaches save_overload: its lock is released when
    numba's compile event ends with the exception."""
    from numba.core import event

    class ReleaseOnFailure(event.Listener):
        def on_start(self, ev):
            pass

        def on_end(self, ev):
            cache = getattr(ev.data.get("dispatcher"), "_cache", None)
            failed = getattr(ev, "_exc_details", None) is not None  # Event.is_failed answers the opposite
            if failed and isinstance(getattr(getattr(cache, "_impl", None), "locator", None), locator_class):
                _release_compile_lock(cache)

    event.register("numba:compile", ReleaseOnFailure())


@contextmanager
def _index_lock(cache):
    """An exclusive lock on the function's `<index>.lock` while it saves (POSIX; elsewhere no lock)."""
    try:
        import fcntl
    except ImportError:  # Windows: numba's unlocked save
        yield
        return
    os.makedirs(cache._cache_path, exist_ok=True)
    with open(f"{cache._cache_file._index_path}.lock", "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _discard_index(cache, exc: Exception) -> None:
    """Remove a function's cache index (its data files are then unreferenced and overwritten as numbered), with
    one line on stderr naming the file and the error, and whether it could be removed."""
    index = getattr(cache._cache_file, "_index_path", "")
    try:
        os.remove(index)
        done = DAMAGED_NOTICE
    except FileNotFoundError:
        done = DAMAGED_NOTICE
    except OSError as cause:
        done = f"liaison: a damaged compiled-code cache entry could not be removed ({cause.strerror}); it is compiled again in memory"
    print(f"{done}: {index} ({type(exc).__name__}: {exc})"[:400], file=sys.stderr, flush=True)
