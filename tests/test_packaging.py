"""The wheel carries the package data: the shipped scenarios (so the paper commands run from any folder of an
installed wheel, scenario.shipped), the scenario templates, the report's tables and the orbit catalogue."""

import importlib.util
import shutil
import subprocess
import sys
import time
import zipfile

import pytest

from tests.conftest import REPO

PACKAGE = REPO / "liaison_cli"


def _builds_offline() -> bool:
    """The running environment has a wheel-building setuptools that pyproject.toml's build-system accepts (77 or
    later: the SPDX license string): then no build isolation (no index needed)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        major = int(version("setuptools").split(".")[0])
    except (PackageNotFoundError, ValueError):
        return False
    wheel_building = importlib.util.find_spec("wheel") or importlib.util.find_spec("setuptools.command.bdist_wheel")
    return major >= 77 and bool(wheel_building)


def test_the_wheel_holds_every_shipped_scenario_and_data_file(tmp_path):
    """Built as `pip install .` builds it, from a copy of what the build reads (no build/ left in the
    checkout). Without a wheel-building setuptools here, pip builds in isolation (setuptools from the index,
    as for a user; about 5 s with pip's cache). Measured: 5.0 s on the shared 2-core machine; printed with -s."""
    source = tmp_path / "src"
    source.mkdir()
    for name in ("pyproject.toml", "README.md", "MANIFEST.in", "tools/build_commit.py"):
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(REPO / name, source / name)
    shutil.copytree(PACKAGE, source / "liaison_cli", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    started = time.perf_counter()
    isolation = ["--no-build-isolation"] if _builds_offline() else []
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "-q", *isolation,
                           "-w", str(tmp_path / "dist")], capture_output=True, text=True, timeout=600)
    print(f"pip wheel ({'no isolation' if isolation else 'isolated'}): {time.perf_counter() - started:.1f} s")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (wheel,) = (tmp_path / "dist").glob("liaison-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = "liaison_cli/shipped_scenarios/"
    for folder in ("", "003/", "004/", "links/"):
        assert any(n.startswith(shipped + folder) and n.endswith(".yaml") and "/" not in n[len(shipped + folder):]
                   for n in names), folder
    assert shipped + "liaison-scenario.schema.json" in names
    assert {shipped + "004/eml2_halo.yaml", shipped + "003/cassini.yaml", shipped + "eml2_lunar.yaml",
            shipped + "links/turan2022_table2.yaml"} <= names
    # Every file of the package that is not code is in the wheel (a new data folder needs its package-data).
    data = {p.relative_to(REPO).as_posix() for p in PACKAGE.rglob("*")
            if p.is_file() and p.suffix not in (".py", ".pyc") and "__pycache__" not in p.parts}
    assert data and not data - names, sorted(data - names)


@pytest.mark.slow  # about 13 minutes on 2 cores: a wheel, a fresh venv, and some 220 commands
def test_every_shipped_name_help_example_and_docs_command_works_from_a_wheel_in_an_empty_folder(tmp_path):
    """issue 47: benchmarks.wheel_walk builds the committed tree's wheel, installs it in a fresh venv and runs, each
    in an empty folder, every shipped scenario by name, every --help example and every docs command; none fails
    (the skipped ones, placeholders and a page's own YAML, are listed with their reason)."""
    from benchmarks.wheel_walk import main

    output = tmp_path / "walk.md"
    main(["--output", str(output), "--jobs", "2"])
    text = output.read_text()
    totals = [line for line in text.splitlines() if line.startswith("Totals (")]
    assert len(totals) == 3 and all(" 0 failed" in line for line in totals), totals
