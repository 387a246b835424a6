"""What the two on-disk orbit caches (orbits.family_store, orbits.corrected_store) share: a folder in the
user cache, NumPy .npz files (no pickles) written atomically (storage), and a damaged file told apart from
a good one, noted on stderr and left to the caller to rebuild (the cache is derived data)."""

import io
import sys
from pathlib import Path

import numpy as np

from liaison_cli import user_cache_dir
from liaison_cli.storage import write_bytes_atomic


def cache_folder(name: str) -> Path:
    """`$LIAISON_CACHE_DIR/NAME` (default `~/.cache/liaison/NAME`)."""
    return Path(user_cache_dir()) / name


def write_npz(arrays: dict, path: Path) -> None:
    """The arrays (name -> array) as one .npz at `path`, written atomically."""
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    write_bytes_atomic(buffer.getvalue(), path)


def read_intact(path: Path, read, cache: str, remedy: str):
    """read(path) -> (value, None), or (anything, problem) for a file that loads but is malformed: the value,
    or None with one note on stderr (`damaged CACHE cache (problem); REMEDY`) when the file is damaged. A
    damaged zip fails in many ways (BadZipFile, EOFError, KeyError, ValueError): any error but a
    PermissionError (which a rebuild would meet too) counts as damage; a file gone meanwhile is None, silently."""
    try:
        value, problem = read(path)
    except FileNotFoundError:  # gone since the caller looked (another process evicted it): a miss, not damage
        return None
    except Exception as exc:  # noqa: BLE001 - see the docstring
        if isinstance(exc, PermissionError):
            raise
        problem = type(exc).__name__
    if problem is None:
        return value
    print(f"liaison: {path}: damaged {cache} cache ({problem}); {remedy}", file=sys.stderr)
    return None
