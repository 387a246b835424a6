"""Provenance of the arithmetic: what, besides the code and the scenario, decides a result's last bits.

The same scenario and seed can give numbers that differ in their last digits on another machine: OpenBLAS picks
its kernels for the CPU it runs on (numpy's copy for np.linalg in Python, scipy's copy for np.linalg inside
numba-compiled code), numba compiles for the host CPU's instruction set, and a library upgrade can change
either. `arithmetic_provenance()` names all of that, so two results that disagree can be told apart; every
result's metadata carries it under the key "arithmetic", and `liaison --version --verbose` prints it.

It is a record, never a key: a result is reused whatever machine computed it (no cache key or resume check
includes it).
"""

import ctypes
import functools
import os
import platform
import re
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from importlib.util import find_spec
from pathlib import Path

VERSIONED = ("numpy", "scipy", "numba", "llvmlite", "pyarrow")
# Read once, when a library loads: OpenBLAS's kernel choice, numba's target CPU and its features, thread counts
# (a threaded BLAS can split a sum differently). Unset in the parent, liaison sizes each worker's thread pools
# itself (campaign.engine.backends: cores / --jobs).
ARITHMETIC_VARIABLES = ("OPENBLAS_CORETYPE", "NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "OMP_NUM_THREADS",
                        "OPENBLAS_NUM_THREADS")
# OpenBLAS's name for the kernel set it chose at load time; scipy-openblas builds prefix (and, with 64-bit
# integers, suffix) every symbol.
CORENAME_SYMBOLS = ("scipy_openblas_get_corename64_", "scipy_openblas_get_corename", "openblas_get_corename64_",
                    "openblas_get_corename")
# An installed copy has no .git beside it: a wheel built from a checkout carries the commit in this file of the
# package (written by the build, tools/build_commit.py; absent when the build had no checkout).
BUILD_COMMIT_FILE = "build_commit.txt"


@functools.cache
def arithmetic_provenance() -> dict[str, str | None]:
    """Library versions, each BLAS and the kernel it runs, the CPU, the variables that steer them and the
    checkout's commit (an installed copy's: the one it was built from), as a flat dict (None: not known or not
    set). Computed once per process (the libraries read their variables once too); the dict is shared, so copy
    it before changing it. It imports numpy and scipy, which a campaign has loaded already, and nothing else of
    weight."""
    facts: dict[str, str | None] = {"python": platform.python_version()}
    for name in VERSIONED:
        facts[name] = _distribution_version(name)
    for package in ("numpy", "scipy"):
        facts[f"{package}_blas"] = _blas_name(package)  # imports the package: its OpenBLAS is the one loaded
        facts[f"{package}_blas_core"] = _openblas_core(package)
    facts["cpu"] = _cpu_model()
    facts["machine"] = platform.machine() or None
    facts.update({name: os.environ.get(name) for name in ARITHMETIC_VARIABLES})
    package = Path(__file__).resolve().parent
    facts["git_commit"] = git_commit(package.parent) or recorded_commit(package)
    return facts


def _distribution_version(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def _blas_name(package: str) -> str | None:
    """The BLAS `package` was built against, as its own show_config reports it ("scipy-openblas 0.3.31")."""
    try:
        blas = import_module(package).show_config(mode="dicts")["Build Dependencies"]["blas"]
        return f"{blas['name']} {blas['version']}"
    except (ImportError, AttributeError, KeyError, TypeError):
        return None


def _openblas_core(package: str) -> str | None:
    """The kernel set ("Haswell", "SkylakeX", "Zen", ...) of the OpenBLAS bundled in `package`'s wheel
    (<site-packages>/<package>.libs on Linux and Windows, <package>/.dylibs on macOS). The package is imported
    first, so ctypes gets the copy already loaded; None for another BLAS or a build without a bundled one."""
    spec = find_spec(package)
    if spec is None or spec.origin is None:
        return None
    root = Path(spec.origin).parent
    for library in sorted([*root.parent.glob(f"{package}.libs/*openblas*"), *root.glob(".dylibs/*openblas*")]):
        try:
            loaded = ctypes.CDLL(str(library))
        except OSError:
            continue
        for symbol in CORENAME_SYMBOLS:
            corename = getattr(loaded, symbol, None)
            if corename is not None:
                corename.restype = ctypes.c_char_p
                return corename().decode().strip() or None
    return None


def _cpu_model() -> str | None:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as cpuinfo:
            for line in cpuinfo:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or None


def git_commit(checkout: Path) -> str | None:
    """The commit checked out at `checkout` (liaison run from a clone or installed editable), read from its .git
    without needing git; None for an installed copy (site-packages has no .git: see recorded_commit) or
    anything unreadable. Local edits do not show: for the code itself, see the sweep tables' core_hash."""
    git = checkout / ".git"
    try:
        if git.is_file():  # a worktree or a submodule: "gitdir: <path>"
            git = checkout / git.read_text().partition("gitdir:")[2].strip()
        head = (git / "HEAD").read_text().strip()
        if not head.startswith("ref:"):
            return _commit_or_none(head)  # a detached HEAD holds the commit itself
        ref = head.partition("ref:")[2].strip()
        common = git / (git / "commondir").read_text().strip() if (git / "commondir").is_file() else git
        for folder in (git, common):
            if (folder / ref).is_file():
                return _commit_or_none((folder / ref).read_text().strip())
        packed = common / "packed-refs"
        if packed.is_file():
            for line in packed.read_text().splitlines():
                commit, _, name = line.partition(" ")
                if name.strip() == ref:
                    return _commit_or_none(commit)
    except (OSError, UnicodeDecodeError):
        pass
    return None


def recorded_commit(package: Path) -> str | None:
    """The commit the build wrote into the installed package `package` (BUILD_COMMIT_FILE); None when the build
    had none (no checkout), or the file is unreadable or holds no commit."""
    try:
        return _commit_or_none((package / BUILD_COMMIT_FILE).read_text(encoding="ascii").strip())
    except (OSError, UnicodeDecodeError):
        return None


def _commit_or_none(text: str) -> str | None:
    return text if re.fullmatch(r"[0-9a-f]{40}|[0-9a-f]{64}", text) else None
