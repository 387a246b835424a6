"""Provenance of the arithmetic (liaison_cli.provenance): the record names the libraries, BLAS kernels, CPU,
variables and commit that decide a result's last digits; every result's metadata carries it; and it is a record
only: a stored cell or a sweep's finished tasks are reused whatever it says."""

import json
import os
import platform
import shutil
import subprocess
import sys

import llvmlite
import numba
import numpy as np
import pandas as pd
import pyarrow
import pytest
import scipy

from liaison_cli.campaign.studies.study_cells import CellStore
from liaison_cli.campaign.sweep.plan import plan_sweep
from liaison_cli.campaign.sweep.run import run_sweep
from liaison_cli.provenance import ARITHMETIC_VARIABLES, arithmetic_provenance, git_commit
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.storage import read_metadata
from tests.conftest import REPO, SCENARIOS, run_cli_in_process

COMMIT = "0123456789abcdef0123456789abcdef01234567"


@pytest.fixture
def fresh_record():
    """The cached record is dropped before and after, so a patched variable reaches the test and no further."""
    arithmetic_provenance.cache_clear()
    yield
    arithmetic_provenance.cache_clear()


def test_the_record_names_the_libraries_this_process_runs(fresh_record):
    record = arithmetic_provenance()
    assert record["python"] == platform.python_version()
    for module in (np, scipy, numba, llvmlite, pyarrow):
        assert record[module.__name__] == module.__version__, module.__name__
    blas = np.show_config(mode="dicts")["Build Dependencies"]["blas"]
    assert record["numpy_blas"] == f"{blas['name']} {blas['version']}"
    assert record["scipy_blas"].split()[0] == scipy.show_config(mode="dicts")["Build Dependencies"]["blas"]["name"]
    assert set(ARITHMETIC_VARIABLES) <= set(record) and record["machine"] == platform.machine()
    if sys.platform == "linux":
        assert record["cpu"]
    if "openblas" in blas["name"]:  # a wheel's bundled OpenBLAS: its kernel is read from the library itself
        assert record["numpy_blas_core"]
    assert all(isinstance(key, str) and (value is None or isinstance(value, str)) for key, value in record.items())
    assert arithmetic_provenance() is record  # computed once per process


def test_a_variable_set_in_the_environment_is_in_the_record(monkeypatch, fresh_record):
    monkeypatch.setenv("OPENBLAS_CORETYPE", "Haswell")
    monkeypatch.delenv("NUMBA_CPU_NAME", raising=False)
    record = arithmetic_provenance()
    assert record["OPENBLAS_CORETYPE"] == "Haswell" and record["NUMBA_CPU_NAME"] is None


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="OpenBLAS core names of x86-64")
def test_the_blas_core_is_the_one_openblas_chose_at_load_time():
    """OPENBLAS_CORETYPE forces a kernel set other than this CPU's (and than the build's default, Haswell):
    the record shows the forced one, so it is read from the loaded library, not from its build options."""
    if arithmetic_provenance()["numpy_blas_core"] is None:
        pytest.skip("numpy without a bundled OpenBLAS")
    code = "from liaison_cli.provenance import arithmetic_provenance as a; r = a(); print(r['numpy_blas_core'])"
    proc = subprocess.run([sys.executable, "-c", code], env={**os.environ, "OPENBLAS_CORETYPE": "Sandybridge"},
                          capture_output=True, text=True, check=True, timeout=120)
    assert proc.stdout.strip() == "Sandybridge"


def test_the_commit_is_read_from_the_checkout_without_git(tmp_path):
    assert git_commit(tmp_path) is None  # an installed copy: no .git beside the package
    git = tmp_path / "clone" / ".git"
    (git / "refs" / "heads").mkdir(parents=True)
    (git / "HEAD").write_text("ref: refs/heads/main\n")
    (git / "refs" / "heads" / "main").write_text(COMMIT + "\n")
    assert git_commit(tmp_path / "clone") == COMMIT
    (git / "refs" / "heads" / "main").unlink()  # after `git gc`: the branch is in packed-refs
    (git / "packed-refs").write_text(f"# pack-refs with: peeled fully-peeled sorted\n{COMMIT} refs/heads/main\n")
    assert git_commit(tmp_path / "clone") == COMMIT
    (git / "HEAD").write_text(COMMIT[::-1] + "\n")  # detached
    assert git_commit(tmp_path / "clone") == COMMIT[::-1]
    worktree = tmp_path / "worktree"
    worktree.mkdir()
    (worktree / ".git").write_text(f"gitdir: {git}\n")
    assert git_commit(worktree) == COMMIT[::-1]


@pytest.mark.skipif(not (REPO / ".git").exists() or shutil.which("git") is None, reason="not a git checkout")
def test_the_record_names_this_checkouts_commit(fresh_record):
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True, text=True)
    if head.returncode != 0:  # e.g. a checkout owned by another user (git's safe.directory)
        pytest.skip(head.stderr.strip())
    assert arithmetic_provenance()["git_commit"] == head.stdout.strip()


def test_a_run_records_the_arithmetic_in_every_table(tmp_path, monkeypatch, fresh_record):
    monkeypatch.setenv("OPENBLAS_CORETYPE", "Haswell")
    out = tmp_path / "run"
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--jobs", "1", "--quiet",
                              "--output", out, "--json")
    assert proc.returncode == 0, proc.stderr
    for table in ("summary", "timeseries", "consistency"):
        recorded = read_metadata(out / f"{table}.parquet")["arithmetic"]
        assert recorded == arithmetic_provenance(), table
    assert recorded["numpy"] == np.__version__ and recorded["OPENBLAS_CORETYPE"] == "Haswell"
    assert json.loads(proc.stdout)["arithmetic"] == recorded


def _other_arithmetic(monkeypatch):
    """From here on this process records other arithmetic (as another machine would), wherever it is asked."""
    monkeypatch.setenv("OPENBLAS_CORETYPE", "another-core")  # OpenBLAS is loaded: only the record changes
    arithmetic_provenance.cache_clear()


def test_a_stored_cell_is_reused_whatever_arithmetic_computed_it(tmp_path, monkeypatch, fresh_record):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    computed = []

    def cell():
        store = CellStore(tmp_path / "work", "test", "code")
        return store.cell("cell", scenario, 2, lambda: computed.append(1) or {"t": pd.DataFrame({"v": [1.0]})})

    cell()
    first = arithmetic_provenance()
    _other_arithmetic(monkeypatch)
    cell()
    assert len(computed) == 1
    done = json.loads(next((tmp_path / "work").glob("cell-*.done")).read_text())
    assert done["arithmetic"] == first != arithmetic_provenance()  # the record of what computed it


def test_a_sweep_resumed_under_other_arithmetic_reuses_its_finished_tasks(tmp_path, monkeypatch, fresh_record):
    scenario, text = load_scenario(SCENARIOS / "smoke.yaml")
    plan = plan_sweep([(scenario, text, "smoke.yaml")], [("noise.sigma_m", [150])], 1, "p")
    run_sweep(plan, tmp_path / "s", jobs=1, progress=False)
    _other_arithmetic(monkeypatch)
    again = run_sweep(plan, tmp_path / "s", jobs=1, progress=False)
    assert again.computed == 0 and again.reused == 1
    assert json.loads((tmp_path / "s" / "sweep.json").read_text())["arithmetic"]["OPENBLAS_CORETYPE"] == "another-core"
