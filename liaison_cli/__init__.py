"""liaison: Monte Carlo campaigns for autonomous cislunar orbit determination (LiAISON)."""

import hashlib
import os
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

try:
    __version__ = version("liaison")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+source"

# Compiled (numba) modules; their on-disk cache must be invalidated when any of them changes.
COMPILED_PACKAGES = ("dynamics", "measurements", "estimation")


def core_source_hash(packages=COMPILED_PACKAGES) -> str:
    """Hash of the sources of `packages` (default: every compiled module). numba keys a cached function
    on its own file only, so a change in a callee (say the RK4 step inlined into the filter loop) would
    otherwise leave stale machine code in the cache."""
    digest = hashlib.sha256()
    root = Path(__file__).parent
    for package in packages:
        for path in sorted((root / package).glob("*.py")):
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def user_cache_dir() -> str:
    """`$LIAISON_CACHE_DIR`, else `$XDG_CACHE_HOME/liaison`, else `~/.cache/liaison`."""
    return os.environ.get("LIAISON_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "liaison"
    )


def _numba_cache_dir() -> str:
    return os.path.join(user_cache_dir(), f"numba-{core_source_hash()}")


# Must happen before numba is imported (it reads the variable once, at import).
os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
