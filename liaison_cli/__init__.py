"""liaison: Monte Carlo campaigns for autonomous cislunar orbit determination (LiAISON)."""

import ast
import hashlib
import json
import os
import sys
from pathlib import Path


def __getattr__(name: str):
    """`__version__` on first use (importlib.metadata is the package import's largest part, and `python -m
    liaison_cli` imports this package before its entry point can turn a Ctrl-C into one line)."""
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("liaison")
        except PackageNotFoundError:  # running from a source tree that is not installed
            value = "0.0.0+source"
        globals()["__version__"] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

# Compiled (numba) modules; their on-disk cache must be invalidated when any of them changes.
COMPILED_PACKAGES = ("dynamics", "measurements", "estimation", "analysis")
# Every package whose code shapes a run's numbers (the derived default noise and its LinCov check included): a
# resumable result (a sweep's manifest) is keyed on their hash, so a resume never mixes runs of different code.
RESULT_PACKAGES = ("dynamics", "radio", "orbits", "measurements", "estimation", "analysis", "exchange", "scenario",
                   "campaign")


def core_source_hash(packages=COMPILED_PACKAGES) -> str:
    """Hash of the code of `packages` (default: every compiled module). numba keys a cached function on its
    own file only, so a change in a callee (say the RK4 step inlined into the filter loop) would otherwise
    leave stale machine code in the cache. Only the code counts (`code_digest`): an edited comment or
    docstring keeps the key, so it does not cost everyone a full recompile."""
    digest = hashlib.sha256()
    root = Path(__file__).parent
    memo = _DigestMemo()
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):  # sub-packages too (dynamics.integrators)
            digest.update(path.relative_to(root / package).as_posix().encode())
            digest.update(memo.code_digest(path.read_bytes()).encode())
    memo.save()
    return digest.hexdigest()[:16]


def code_digest(source: bytes) -> str:
    """sha256 of a module's syntax tree without docstrings or other bare string statements (comments and
    layout never reach the tree; line numbers are left out of the dump)."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list):
            kept = [s for s in body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant)
                                            and isinstance(s.value.value, str))]
            node.body = kept or [ast.Pass()]
    return hashlib.sha256(ast.dump(tree).encode()).hexdigest()


class _DigestMemo:
    """code_digest by the sha256 of a file's bytes, kept in `user_cache_dir()/code-digests.json`: parsing the
    numeric core costs about 0.1 s, paid on every import otherwise. Keyed by content, so it cannot go stale;
    an unreadable memo is only recomputed, and one that cannot be written is skipped."""

    LIMIT = 1000  # a few checkouts' worth of the ~110 modules study cells hash (campaign.studies.study_cells)

    def __init__(self):
        self.path = Path(user_cache_dir()) / "code-digests.json"
        try:
            self.entries = dict(json.loads(self.path.read_text()))
        except (OSError, ValueError, TypeError):
            self.entries = {}
        self.changed = False

    def code_digest(self, source: bytes) -> str:
        key = hashlib.sha256(source).hexdigest()
        if not isinstance(self.entries.get(key), str):
            self.entries[key] = code_digest(source)
            self.changed = True
        return self.entries[key]

    def save(self) -> None:
        if not self.changed:
            return
        from liaison_cli.storage import write_text_atomic

        kept = dict(list(self.entries.items())[-self.LIMIT :])
        try:
            write_text_atomic(json.dumps(kept), self.path)
        except OSError:
            pass  # a read-only cache folder: the next import parses again


def user_cache_dir() -> str:
    """`$LIAISON_CACHE_DIR`, else `$XDG_CACHE_HOME/liaison`, else `~/.cache/liaison`."""
    return os.environ.get("LIAISON_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "liaison"
    )


def _numba_cache_dir() -> str:
    return os.path.join(user_cache_dir(), f"numba-{core_source_hash()}")


COMPILED_PACKAGE_MODULES = tuple(f"{__name__}.{package}" for package in COMPILED_PACKAGES)


def use_cache_dir(path: str) -> str:
    """Make `path` this process's cache folder (LIAISON_CACHE_DIR, with numba's folder in it) and its worker
    processes' (they inherit the environment); returns numba's folder. Only before a compiled package is
    imported: numba fixes a function's cache folder when its decorator runs."""
    loaded = [name for name in COMPILED_PACKAGE_MODULES if name in sys.modules]
    if loaded:
        raise RuntimeError(f"use_cache_dir: {', '.join(loaded)} already imported with the cache "
                           f"{os.environ['NUMBA_CACHE_DIR']}")
    os.environ["LIAISON_CACHE_DIR"] = os.path.abspath(path)
    os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
    if "numba" in sys.modules:
        sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
    return os.environ["NUMBA_CACHE_DIR"]


# numba reads the variable once, at import; imported before us (a notebook, a profiler, a test plugin), it has
# read it already, and would cache liaison's kernels beside their source under a key that ignores the callees.
os.environ["NUMBA_CACHE_DIR"] = _numba_cache_dir()
# One compile target for every machine of an architecture, so a cache built on one serves another
# (compiled_cache; measured to cost no run time, docs/performance.md). A user's own setting is kept.
# Only before numba is imported: afterwards its code generator may exist already for the host CPU, and a
# changed setting would label host code "generic" in the cache's keys (that process compiles for its host).
if "numba" not in sys.modules:
    os.environ.setdefault("NUMBA_CPU_NAME", "generic")
else:
    sys.modules["numba"].config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]
