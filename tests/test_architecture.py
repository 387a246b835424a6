"""Architecture: one direction of flow, no import cycles, pure-numeric core, observables owned by measurements/.

Layers, lowest first; a module may import from its own layer or lower ones only, counting imports inside
functions too (a lazy import hides a dependency, it does not remove it):
base (package root, errors, storage, interrupts, provenance, compiled_cache, compiled_calls) -> dynamics, radio -> orbits -> measurements -> estimation -> analysis
-> exchange -> scenario -> campaign -> report -> cli.
"""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import liaison_cli

PACKAGE = Path(liaison_cli.__file__).parent
CORE_PACKAGES = ["dynamics", "orbits", "radio", "measurements", "estimation"]
FORBIDDEN = {"yaml", "pandas", "typer", "joblib", "pyarrow", "tqdm", "pydantic", "json", "pickle"}
LAYERS = [
    {"__init__", "errors", "storage", "interrupts", "provenance", "compiled_cache", "compiled_calls"},
    {"dynamics", "radio"},
    {"orbits"},
    {"measurements"},
    {"estimation"},
    {"analysis"},
    {"exchange"},
    {"scenario"},
    {"campaign"},
    {"report"},
    {"cli", "__main__", "api"},
]
# Every registered observable's name (so a new kind is guarded from the day it is registered), and the LOS
# angles' names.
OBSERVABLE_WORDS = set(__import__("liaison_cli.measurements.registry", fromlist=["OBSERVABLES"]).OBSERVABLES) | {
    "azimuth", "elevation"}


def _imported_roots(path: Path) -> set[str]:
    roots = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            roots |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            roots.add(node.module.split(".")[0])
    return roots


def _module_name(package_root: Path, path: Path) -> str:
    parts = path.relative_to(package_root).with_suffix("").parts
    return ".".join(p for p in parts if p != "__init__") or "__init__"


def _internal_imports(package_root: Path, path: Path) -> set[str]:
    """Modules of the package imported anywhere in `path` (from x import y counts y if it is a module)."""
    name = package_root.name
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name[len(name) + 1 :] or "__init__" for a in node.names if a.name.split(".")[0] == name}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] != name:
                continue
            base = node.module[len(name) + 1 :] or "__init__"
            for alias in node.names:
                sub = f"{base}.{alias.name}" if base != "__init__" else alias.name
                is_module = (package_root / Path(*sub.split("."))).with_suffix(".py").exists() or (
                    package_root / Path(*sub.split("."))).is_dir()
                out.add(sub if is_module else base)
    return out


def import_graph(package_root: Path) -> dict[str, set[str]]:
    return {_module_name(package_root, p): _internal_imports(package_root, p) for p in package_root.rglob("*.py")}


def _layer(module: str) -> int:
    top = module.split(".")[0]
    for index, layer in enumerate(LAYERS):
        if top in layer:
            return index
    raise AssertionError(f"module {module!r} is in no layer: place it in LAYERS")


def layer_violations(graph) -> list[str]:
    return sorted(f"{a} (layer {_layer(a)}) imports {b} (layer {_layer(b)})"
                  for a, deps in graph.items() for b in deps if _layer(b) > _layer(a))


def import_cycles(graph) -> list[list[str]]:
    """Strongly connected components with more than one module, or a module importing itself."""
    index, low, stack, on_stack, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph.get(v, ()):
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return cycles


def test_layer_order_holds():
    assert layer_violations(import_graph(PACKAGE)) == []


def test_no_import_cycles():
    assert import_cycles(import_graph(PACKAGE)) == []


def _write_fake_package(root: Path, files: dict) -> Path:
    package = root / "liaison_cli"
    for name, text in files.items():
        path = package / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return package


def test_the_checks_catch_a_violating_import(tmp_path):
    """The checks can fail: a dynamics module importing the campaign, and a lazy two-module cycle."""
    package = _write_fake_package(tmp_path, {
        "__init__.py": "",
        "dynamics/__init__.py": "",
        "dynamics/crtbp.py": "def f():\n    from liaison_cli.campaign.engine import runner\n",
        "campaign/__init__.py": "",
        "campaign/engine/runner.py": "from liaison_cli.campaign.sweep.run import x\n",
        "campaign/sweep/run.py": "def g():\n    import liaison_cli.campaign.engine.runner\n",
    })
    graph = import_graph(package)
    assert layer_violations(graph) == ["dynamics.crtbp (layer 1) imports campaign.engine.runner (layer 8)"]
    assert import_cycles(graph) == [["campaign.engine.runner", "campaign.sweep.run"]]


def test_core_source_imports_no_io_libraries():
    offenders = {}
    for package in CORE_PACKAGES:
        for path in (PACKAGE / package).rglob("*.py"):
            bad = _imported_roots(path) & FORBIDDEN
            if bad:
                offenders[str(path.relative_to(PACKAGE))] = sorted(bad)
    assert offenders == {}


def test_importing_the_core_loads_no_io_libraries():
    # yaml is left out here only because numba itself reads its optional config file with it.
    modules = [f"liaison_cli.{_module_name(PACKAGE, f)}" for p in CORE_PACKAGES
               for f in (PACKAGE / p).rglob("*.py")]
    watched = sorted(FORBIDDEN - {"yaml", "json", "pickle"})
    code = (
        f"import sys\nfor m in {modules!r}: __import__(m)\n"
        f"print(','.join(m for m in {watched!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_liaison_run_loads_only_what_it_needs(tmp_path):
    """Issue 13: a command does not pay for imports it does not use. A small `liaison run` writes its Parquet
    without pandas (0.3 s), stays in its process without joblib, and takes its chi-square bounds without
    scipy.special / scipy.stats; its truth needs no scipy.integrate. The check is run in a fresh process."""
    unwanted = ["pandas", "joblib", "scipy.special", "scipy.stats", "scipy.integrate", "scipy.optimize", "matplotlib"]
    scenario = PACKAGE.parent / "scenarios" / "smoke.yaml"
    code = (
        "import sys\nfrom liaison_cli.cli import app\n"
        f"try:\n    app(['run', {str(scenario)!r}, '--quiet', '--output', {str(tmp_path / 'out')!r}])\n"
        "except SystemExit as stop:\n    assert stop.code == 0, stop.code\n"
        f"print('loaded: ' + ','.join(m for m in {unwanted!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "2/2 runs ok" in out.stdout
    assert out.stdout.strip().splitlines()[-1] == "loaded:", out.stdout
    assert (tmp_path / "out" / "summary.parquet").exists()


def test_a_command_that_runs_no_filter_does_not_load_scipy_linalg():
    """`liaison validate` (as `scenarios`, `new` and the other commands that run no filter) does not import
    scipy.linalg (about 0.27 s a launch; it is imported where a filter runs, by the compiled code's LAPACK)."""
    scenario = PACKAGE.parent / "scenarios" / "smoke.yaml"
    code = (
        "import sys\nfrom liaison_cli.cli import app\n"
        f"try:\n    app(['validate', {str(scenario)!r}])\n"
        "except SystemExit as stop:\n    assert stop.code == 0, stop.code\n"
        "print('loaded: ' + ','.join(m for m in ['scipy.linalg'] if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "loaded:", out.stdout


def observable_vocabulary_outside_measurements(package_root: Path) -> list[str]:
    """Kind codes defined or imported, or an observable's name compared against, outside measurements/."""
    found = []
    for path in package_root.rglob("*.py"):
        module = _module_name(package_root, path)
        if module.startswith("measurements"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                found += [f"{module}: defines {t.id}" for t in targets
                          if isinstance(t, ast.Name) and t.id.startswith("KIND_")]
            elif isinstance(node, ast.ImportFrom):
                found += [f"{module}: imports {a.name}" for a in node.names if a.name.startswith("KIND_")]
            elif isinstance(node, ast.Compare):
                for operand in [node.left, *node.comparators]:
                    if isinstance(operand, ast.Constant) and operand.value in OBSERVABLE_WORDS:
                        found.append(f"{module}: compares with {operand.value!r}")
    return sorted(found)


def test_observable_vocabulary_lives_in_measurements_only():
    assert observable_vocabulary_outside_measurements(PACKAGE) == []


@pytest.mark.parametrize("text", ["KIND_RANGE = 0\n", "from liaison_cli.measurements.range import KIND_RANGE\n",
                                  "def f(o):\n    return o == 'range_rate'\n"])
def test_the_vocabulary_check_catches_a_branch_on_kind(tmp_path, text):
    package = _write_fake_package(tmp_path, {"__init__.py": "", "estimation/__init__.py": "",
                                             "estimation/loop.py": text})
    assert len(observable_vocabulary_outside_measurements(package)) == 1


def test_every_library_the_package_imports_is_a_declared_dependency():
    """A module imported by liaison_cli (lazily or not) comes from the standard library, from liaison_cli, or
    from a distribution named in pyproject's dependencies or extras: one that is merely installed beside it
    (click arrived with dask here, but typer no longer needs it) would break a clean install."""
    import importlib.metadata
    import re
    import tomllib

    project = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["project"]
    declared_specs = list(project["dependencies"]) + [s for extra in project["optional-dependencies"].values()
                                                      for s in extra]
    declared = {re.split(r"[\[<>=!~ ;]", spec, maxsplit=1)[0].lower().replace("_", "-") for spec in declared_specs}
    for spec in declared_specs:  # dask[distributed] installs the distribution `distributed`
        declared |= {extra.strip().lower() for extra in re.findall(r"\[([^\]]+)\]", spec)[0].split(",")} \
            if "[" in spec else set()
    providers = importlib.metadata.packages_distributions()
    undeclared = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                roots = [alias.name.split(".")[0] for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                roots = [node.module.split(".")[0]]
            else:
                continue
            for root in roots:
                if root in sys.stdlib_module_names or root == "liaison_cli":
                    continue
                names = {d.lower().replace("_", "-") for d in providers.get(root, [root])}
                if not names & declared:
                    undeclared.add(f"{path.relative_to(PACKAGE.parent)}: {root} ({', '.join(sorted(names))})")
    assert not undeclared, sorted(undeclared)


# Roles (issue 36, one study template): a study's computation lives in campaign/ (campaign.studies), report/
# formats and draws what it returns, campaign.studies.output writes it through storage/, and the CLI only puts
# the parts together and prints. Two checks hold the ends of that line.

# What writes a file or a folder: storage's writers, pandas' and matplotlib's, pathlib's. `resumable_output` is
# not among them: `liaison sweep` hands the folder it settles to the sweep (campaign.sweep.run), which writes.
FILE_WRITERS = {"write_parquet_atomic", "write_text_atomic", "write_bytes_atomic", "write_columns_atomic",
                "write_atomic", "staged_output", "prepare_output_dir", "ParquetStream", "to_parquet", "to_csv",
                "savefig", "write_text", "write_bytes", "mkdir", "touch", "unlink", "rmtree"}


def _writes_with_open(node: ast.Call) -> bool:
    """open(path, mode) or open(path, mode=...) with a mode that writes ('w', 'a', 'x' or '+')."""
    if not (isinstance(node.func, ast.Name) and node.func.id == "open"):
        return False
    modes = [*node.args[1:2], *[k.value for k in node.keywords if k.arg == "mode"]]
    return any(isinstance(m, ast.Constant) and isinstance(m.value, str) and set(m.value) & set("wax+")
               for m in modes)


def file_writes(package_root: Path, folder: str) -> list[str]:
    """Calls of a file writer (FILE_WRITERS, open for writing), and imports of one, in the modules of `folder`."""
    found = []
    for path in sorted((package_root / folder).rglob("*.py")):
        module = _module_name(package_root, path)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call):
                name = getattr(node.func, "id", None) or getattr(node.func, "attr", None)
                if name in FILE_WRITERS or _writes_with_open(node):
                    found.append(f"{module}:{node.lineno}: calls {name}")
            elif isinstance(node, ast.ImportFrom):
                found += [f"{module}:{node.lineno}: imports {a.name}" for a in node.names if a.name in FILE_WRITERS]
    return found


def test_the_cli_writes_no_files():
    """The CLI parses, calls a study's compute function, its report formatter and the writer
    (campaign.studies.output), and prints; it writes nothing itself."""
    assert file_writes(PACKAGE, "cli") == []


@pytest.mark.parametrize("text", [
    "from liaison_cli.storage import staged_output\n",
    "def f(out):\n    with staged_output(out, False) as stage:\n        pass\n",
    "def f(frame, path):\n    frame.to_parquet(path)\n",
    "def f(path):\n    with open(path, 'w') as handle:\n        handle.write('x')\n",
    "def f(path):\n    return open(path, mode='ab')\n",
    "def f(path):\n    path.write_text('x')\n",
    "def f(fig, path):\n    fig.savefig(path)\n",
    "def f(path):\n    path.mkdir(parents=True)\n",
])
def test_the_cli_write_check_catches_a_write(tmp_path, text):
    package = _write_fake_package(tmp_path, {"__init__.py": "", "cli/__init__.py": "", "cli/study.py": text})
    assert len(file_writes(package, "cli")) == 1, file_writes(package, "cli")


def test_the_cli_write_check_lets_reading_pass(tmp_path):
    text = "def f(path):\n    with open(path, 'rb') as handle:\n        return handle.read(), open(path).read()\n"
    package = _write_fake_package(tmp_path, {"__init__.py": "", "cli/__init__.py": "", "cli/study.py": text})
    assert file_writes(package, "cli") == []


# report/ may read the estimator descriptors' registry (what each estimator is called and keeps, to choose which
# channels a run's figures draw); it runs no estimator and computes no study.
REPORT_MAY_IMPORT = {"estimation.estimators"}


def report_reaches_into_computation(package_root: Path) -> list[str]:
    """Modules of report/ that import from campaign/ or estimation/ (lazily too), or name one of their modules in a
    string (importlib.import_module, __import__)."""
    found = []
    for path in sorted((package_root / "report").rglob("*.py")):
        module = _module_name(package_root, path)
        imported = {m for m in _internal_imports(package_root, path) if m.split(".")[0] in ("campaign", "estimation")}
        found += [f"{module}: imports {m}" for m in sorted(imported - REPORT_MAY_IMPORT)]
        found += [f"{module}: names {node.value}" for node in ast.walk(ast.parse(path.read_text()))
                  if isinstance(node, ast.Constant) and isinstance(node.value, str)
                  and node.value.startswith(("liaison_cli.campaign", "liaison_cli.estimation"))]
    return found


def test_report_only_formats_and_draws():
    """report/ formats and draws the frames a study returns: it imports nothing that computes one."""
    assert report_reaches_into_computation(PACKAGE) == []


@pytest.mark.parametrize("text", [
    "from liaison_cli.campaign.studies.table3 import compute_table3\n",
    "def f():\n    from liaison_cli.estimation import ekf\n",
    "import liaison_cli.campaign.engine.runner\n",
    "from liaison_cli.campaign.engine import worker\n",
    "import importlib\nrunner = importlib.import_module('liaison_cli.campaign.engine.runner')\n",
])
def test_the_report_check_catches_a_computation(tmp_path, text):
    package = _write_fake_package(tmp_path, {"__init__.py": "", "report/__init__.py": "", "report/table3.py": text,
                                             "estimation/__init__.py": "", "estimation/estimators.py": ""})
    assert len(report_reaches_into_computation(package)) == 1, report_reaches_into_computation(package)


def test_the_report_check_lets_the_estimator_registry_pass(tmp_path):
    package = _write_fake_package(tmp_path, {
        "__init__.py": "", "report/__init__.py": "", "estimation/__init__.py": "", "estimation/estimators.py": "",
        "report/run_plots.py": "def f():\n    from liaison_cli.estimation.estimators import ESTIMATORS\n"})
    assert report_reaches_into_computation(package) == []
