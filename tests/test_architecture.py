"""The pure-numeric core never imports I/O or CLI libraries."""

import ast
import subprocess
import sys
from pathlib import Path

import liaison_cli

PACKAGE = Path(liaison_cli.__file__).parent
CORE_PACKAGES = ["dynamics", "orbits", "radio", "measurements", "estimation"]
FORBIDDEN = {"yaml", "pandas", "typer", "joblib", "pyarrow", "tqdm", "pydantic", "json", "pickle"}


def _imported_roots(path: Path) -> set[str]:
    roots = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            roots.add(node.module.split(".")[0])
    return roots


def test_core_source_imports_no_io_libraries():
    offenders = {}
    for package in CORE_PACKAGES:
        for path in (PACKAGE / package).glob("*.py"):
            bad = _imported_roots(path) & FORBIDDEN
            if bad:
                offenders[str(path.relative_to(PACKAGE))] = sorted(bad)
    assert offenders == {}


def test_importing_the_core_loads_no_io_libraries():
    # yaml is left out here only because numba itself reads its optional config file with it.
    modules = [f"liaison_cli.{p}.{f.stem}" for p in CORE_PACKAGES for f in (PACKAGE / p).glob("*.py")]
    watched = sorted(FORBIDDEN - {"yaml", "json", "pickle"})
    code = (
        f"import sys\nfor m in {modules!r}: __import__(m)\n"
        f"print(','.join(m for m in {watched!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
