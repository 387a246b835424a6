"""numba's on-disk cache of liaison's compiled kernels: one compile target, a folder keyed on the code, and
entries that heal.

- **Compile target.** The kernels are compiled for a generic x86-64 (or the architecture's generic) CPU
  (`NUMBA_CPU_NAME=generic`, set in the package root before numba is imported, unless the user set it), so
  a cache entry's key names no host CPU: a cache built on CI, in an image or on a colleague's machine serves
  every machine of the same architecture. Measured to cost no run time (docs/performance.md).
- **Locator.** numba files a function's cache under a hash of its source folder's absolute path, so a second
  checkout, a wheel in another environment or a copied cache missed every entry. `PackageLocator` files it
  under the module's folder inside the package, in `NUMBA_CACHE_DIR` (the package root sets that to
  `user_cache_dir()/numba-<hash of the compiled code>`), and stamps it with the sha256 of the module's bytes,
  not its modification time.
- **Healing.** A damaged entry (a truncated or foreign index or data file, as an interrupted copy leaves)
  made every later run fail with numba's UnpicklingError traceback. Now such an entry is removed with one
  line on stderr, compiled again and saved.

`install()` is called by each package that compiles (dynamics, measurements, estimation, analysis) before its
first `@njit(cache=True)`: numba picks a function's locator when the decorator runs.
"""

import hashlib
import os
import sys
from pathlib import Path

PACKAGE_ROOT = Path(__file__).resolve().parent
DAMAGED_NOTICE = "liaison: a damaged compiled-code cache entry was removed and is compiled again"
_installed = False


def _package_folder(py_file: str) -> tuple[str, ...] | None:
    """The parts of py_file's folder below the package root, or None for a file outside the package."""
    try:
        return Path(py_file).resolve().parent.relative_to(PACKAGE_ROOT).parts
    except (OSError, ValueError):
        return None


def _file_digest(path: str) -> str:
    with open(path, "rb") as handle:
        return hashlib.sha256(handle.read()).hexdigest()


def install() -> None:
    """Put PackageLocator first in numba's locator list and make the cache heal damaged entries (once)."""
    global _installed
    if _installed:
        return
    from numba.core import caching, config

    class PackageLocator(caching._CacheLocator):
        """A liaison module's cache folder: NUMBA_CACHE_DIR / liaison_cli / the module's folder in the package;
        freshness: the sha256 of the module's bytes. Not for files outside the package."""

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
            except OSError:  # a cache folder that cannot be written: numba's next locator, or no cache
                return None
            return locator

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    impl._locator_classes = [PackageLocator, *impl._locator_classes]
    _heal_damaged_entries(caching.Cache, PackageLocator)
    _installed = True


def _heal_damaged_entries(cache_class, locator_class) -> None:
    """Wrap numba's Cache.load_overload / save_overload: for a liaison function, an entry that cannot be read
    (any error but a missing file) is removed, said in one line, and reported as a miss, so numba compiles it
    again and saves a sound entry; a save first reads the index it merges into, and removes it the same way if
    it is damaged. Nothing else of a save is touched (a compile interrupted by Ctrl-C fails its save as numba
    made it). Other packages' caches behave as numba made them."""
    load, save = cache_class.load_overload, cache_class.save_overload

    def ours(cache) -> bool:
        return isinstance(getattr(cache._impl, "locator", None), locator_class)

    def load_overload(self, sig, target_context):
        try:
            return load(self, sig, target_context)
        except Exception as exc:  # noqa: BLE001 - any damage to an entry: UnpicklingError, EOFError, ...
            if not ours(self):
                raise
            _discard_index(self, exc)
            return None

    def save_overload(self, sig, data):
        if ours(self):  # a save merges into the index: a damaged one is removed first (a missing one reads {})
            try:
                self._cache_file._load_index()
            except Exception as exc:  # noqa: BLE001 - any damage to the index
                _discard_index(self, exc)
        save(self, sig, data)  # numba's own errors (an interrupted compile, a full disk) stay numba's

    cache_class.load_overload, cache_class.save_overload = load_overload, save_overload


def _discard_index(cache, exc: Exception) -> None:
    """Remove a function's cache index (its data files are then unreferenced and overwritten as numbered), with
    one line on stderr naming the file and the error."""
    index = getattr(cache._cache_file, "_index_path", "")
    try:
        os.remove(index)
    except OSError:
        pass
    print(f"{DAMAGED_NOTICE}: {index} ({type(exc).__name__}: {exc})"[:400], file=sys.stderr, flush=True)
