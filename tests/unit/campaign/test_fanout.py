"""The one fan-out (campaign.engine.backends.map_batches) and what rides on it: a bounded window of work in flight,
the same bytes from `liaison run` on one process, a process pool and dask, the backend options of the long
commands, and which study cells are reused (the 004 study's own resume and dask runs are tested beside it, in
tests/studies/test_study004.py, where its compiled kernels are already loaded)."""

import operator

import pytest

from liaison_cli.campaign.engine import backends, runner
from liaison_cli.campaign.engine.backends import Backend, map_batches
from liaison_cli.campaign.studies.study_cells import CellStore
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS, assert_one_line_error, run_cli_in_process


@pytest.mark.parametrize("ordered", [False, True])
def test_the_pool_never_holds_more_than_its_window(ordered):
    """Batches are read from the caller's iterable only as results are taken: at most `window` are submitted
    and not yet consumed (in order: a batch done before an earlier one included), whatever the number of
    batches (bounded memory for any run count)."""
    taken = {"read": 0, "consumed": 0}

    def batches():
        for index in range(40):
            taken["read"] += 1
            yield 0, index

    results = []
    for value in map_batches(operator.add, {0: 1000}, batches(), Backend("joblib"), jobs=2, window=3, ordered=ordered):
        assert taken["read"] - taken["consumed"] <= 3, taken
        taken["consumed"] += 1
        results.append(value)
    assert (results if ordered else sorted(results)) == [1000 + index for index in range(40)]


def test_run_writes_the_same_bytes_on_one_process_a_pool_and_dask(tmp_path, monkeypatch, sigint_kept):
    """`liaison run` with --jobs 1 (this process), --jobs 2 forced into the pool (runner.POOL_MIN_STATE_EPOCHS
    set to 0, so the comparison can fail) and --backend dask (a LocalCluster): byte-identical Parquet. One run
    per batch here, so runs finish out of order and the reorder buffer is used."""
    short = tmp_path / "smoke.yaml"
    short.write_text((SCENARIOS / "smoke.yaml").read_text().replace("duration_days: 1.25", "duration_days: 0.3"))
    assert "duration_days: 0.3" in short.read_text()
    monkeypatch.setattr(runner, "POOL_MIN_STATE_EPOCHS", 0)
    options = {"one": ["--jobs", "1"], "pool": ["--jobs", "2"], "dask": ["--jobs", "2", "--backend", "dask"]}
    for label, extra in options.items():
        proc = run_cli_in_process("run", short, "--runs", "7", *extra, "--quiet", "--output", tmp_path / label)
        assert proc.returncode == 0, proc.stderr
    for name in ("summary.parquet", "timeseries.parquet", "residuals.parquet", "consistency.parquet"):
        one = (tmp_path / "one" / name).read_bytes()
        assert one == (tmp_path / "pool" / name).read_bytes() == (tmp_path / "dask" / name).read_bytes(), name


def test_runs_that_fly_their_own_truth_give_the_same_bytes_in_the_pool(tmp_path, monkeypatch, sigint_kept):
    """A random truth acceleration (model_error.truth_acceleration_sigma_m_s2): each run draws and flies its own
    truth in whichever process runs it; --jobs 1 and --jobs 2 forced into the pool give identical Parquet."""
    short = tmp_path / "smoke.yaml"
    short.write_text((SCENARIOS / "smoke.yaml").read_text().replace("duration_days: 1.25", "duration_days: 0.3")
                     + "model_error: {truth_acceleration_sigma_m_s2: 1.0e-8, truth_acceleration_time_constant_s: 21600}\n")
    monkeypatch.setattr(runner, "POOL_MIN_STATE_EPOCHS", 0)
    for label, jobs in (("one", "1"), ("pool", "2")):
        proc = run_cli_in_process("run", short, "--runs", "5", "--jobs", jobs, "--quiet", "--output", tmp_path / label)
        assert proc.returncode == 0, proc.stderr
    for name in ("summary.parquet", "timeseries.parquet", "residuals.parquet", "consistency.parquet"):
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "pool" / name).read_bytes(), name


@pytest.mark.parametrize("command", [["run", SCENARIOS / "smoke.yaml"], ["compare", SCENARIOS / "smoke.yaml"],
                                     ["table3"], ["study003"], ["study004"], ["sweep", "--sigma", "100"],
                                     ["tune", SCENARIOS / "smoke.yaml"],
                                     ["errors", SCENARIOS / "smoke.yaml", "--check-runs", "2"]])
def test_every_long_command_checks_its_backend_before_any_work(tmp_path, command, sigint_kept):
    """The shared options (cli.common): an unknown backend, and a scheduler without dask, are one line, exit 2."""
    where = ["--work", tmp_path / "out"] if command[0] == "tune" else ["--output", tmp_path / "out"]
    proc = run_cli_in_process(*command, "--backend", "spark", *where)
    assert_one_line_error(proc, "--backend", ["'spark'", "joblib, dask"])
    proc = run_cli_in_process(*command, "--scheduler", "tcp://127.0.0.1:8786", *where)
    assert_one_line_error(proc, "--scheduler", ["only used with --backend dask"])
    assert not (tmp_path / "out").exists()


def test_a_cell_is_reused_only_for_the_same_scenario_runs_and_liaison(tmp_path, monkeypatch):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    store = CellStore(tmp_path / "work", "test", "code-1")
    computed = []

    def cell(scenario_, runs, store_=store):
        return store_.cell("cell", scenario_, runs, lambda: computed.append(1) or {"t": _frame(len(computed))})

    first = cell(scenario, 2)
    assert cell(scenario, 2)["t"].equals(first["t"]) and len(computed) == 1
    cell(scenario, 3)  # another run count
    cell(apply_overrides(scenario, {"monte_carlo.seed": 8}), 2)  # another scenario
    cell(scenario, 2, CellStore(tmp_path / "work", "test", "code-2"))  # the study's code changed
    monkeypatch.setattr("liaison_cli.campaign.studies.study_cells.__version__", "0.0.0-other")
    cell(scenario, 2)  # another liaison
    assert len(computed) == 5


def _frame(value):
    import pandas as pd

    return pd.DataFrame({"value": [float(value)], "label": ["x"]})


def test_backends_module_is_the_only_place_that_starts_workers():
    """One fan-out path: no other module of the package imports joblib's Parallel or a dask client."""
    from pathlib import Path

    package = Path(backends.__file__).resolve().parents[2]
    starters = ("Parallel(", "get_reusable_executor", "LocalCluster(", "Client(")
    found = sorted(str(path.relative_to(package)) for path in package.rglob("*.py")
                   if any(word in path.read_text() for word in starters))
    assert found == ["campaign/engine/backends.py"], found


def test_an_interrupt_that_compiled_code_turned_into_a_system_error_still_says_what_is_saved(tmp_path):
    """numba reports a Ctrl-C inside compiled code as a SystemError chained to the KeyboardInterrupt: the study
    still ends with its own line (cells saved, how to resume); any other SystemError passes through."""
    from liaison_cli.campaign.studies.study_cells import StudyInterrupted

    store = CellStore(tmp_path / "work", "test", "code")
    with pytest.raises(StudyInterrupted, match=r"interrupted: 0 of 4 cells saved in .*work; rerun the same"):
        with store.saving_on_interrupt(4):
            try:
                raise KeyboardInterrupt
            except KeyboardInterrupt:
                raise SystemError("<built-in function> returned a result with an exception set")
    with pytest.raises(SystemError, match="unrelated"):
        with store.saving_on_interrupt(4):
            raise SystemError("unrelated")


def test_errors_without_a_check_refuses_a_malformed_scheduler_and_does_not_ask_a_silent_one(tmp_path, sigint_kept):
    """`errors` uses the scheduler only for --check-runs: without it, a malformed address is still one line,
    exit 2, while a well-formed one is not connected to (nothing answers at port 1; the budget is written)."""
    scenario = SCENARIOS / "bias_eml2_lunar.yaml"
    proc = run_cli_in_process("errors", scenario, "--backend", "dask", "--scheduler", "nonsense", "--output",
                              tmp_path / "bad")
    assert_one_line_error(proc, "--scheduler", ["'nonsense'", "[tcp|tls]://HOST:PORT"])
    assert not (tmp_path / "bad").exists()
    proc = run_cli_in_process("errors", scenario, "--backend", "dask", "--scheduler", "tcp://127.0.0.1:1",
                              "--scheduler-timeout", "0.5", "--output", tmp_path / "ok")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "ok" / "budget.parquet").exists()


def test_local_workers_are_capped_at_the_cores_with_one_note(monkeypatch, caplog):
    """--jobs above the cores starts no more processes than can run at once (issue 47: 16 on 2 cores started 17
    processes); the note comes once per value, and a count within the cores is kept."""
    import logging
    import os

    from liaison_cli.campaign.engine import backends

    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(backends, "_CAPPED", set())
    with caplog.at_level(logging.WARNING, logger="liaison"):
        assert backends.local_workers(16) == 2 and backends.local_workers(16) == 2
        assert backends.local_workers(2) == 2 and backends.local_workers(1) == 1
    notes = [r.getMessage() for r in caplog.records if "--jobs" in r.getMessage()]
    assert notes == ["--jobs 16 on 2 cores: 2 worker processes (more cannot run at once; the numbers do not "
                     "depend on it)"]


def _interrupt_after(write):
    """`write` that finishes, then a Ctrl-C lands before the caller's next line (the window the counts missed)."""
    def written_then_interrupted(*args, **kwargs):
        write(*args, **kwargs)
        raise KeyboardInterrupt

    return written_then_interrupted


def test_a_ctrl_c_just_after_a_cell_is_written_counts_that_cell(tmp_path, monkeypatch):
    """The count is what is on disk: a Ctrl-C after a cell's `.done` is written but before it was counted said
    '0 of 2' for a saved cell (the CI failure of stop 56, seen on a sweep's manifest)."""
    from liaison_cli.campaign.studies import study_cells
    from liaison_cli.campaign.studies.study_cells import StudyInterrupted

    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    store = CellStore(tmp_path / "work", "test", "code")
    monkeypatch.setattr(study_cells, "write_text_atomic", _interrupt_after(study_cells.write_text_atomic))
    with pytest.raises(StudyInterrupted, match=r"interrupted: 1 of 2 cells saved in "):
        with store.saving_on_interrupt(2):
            store.cell("cell", scenario, 2, lambda: {"t": _frame(1)})


def test_a_ctrl_c_just_after_a_sweep_batch_is_written_counts_that_batch(tmp_path, monkeypatch):
    from liaison_cli.campaign.sweep.manifest import Manifest, read_manifest
    from liaison_cli.campaign.sweep.plan import SweepInterrupted
    from liaison_cli.campaign.sweep.run import run_sweep
    from tests.unit.campaign.test_sweep import _smoke_plan

    plan = _smoke_plan(runs=2, sigmas=(100,))
    writes = []
    real_write = Manifest._write

    def write(self, entries):  # the header, then the first batch: interrupted just after it is on disk
        writes.append(entries)
        (_interrupt_after(real_write) if len(writes) == 2 else real_write)(self, entries)

    monkeypatch.setattr(Manifest, "_write", write)
    with pytest.raises(SweepInterrupted, match=r"interrupted: (\d) of 2 tasks saved in ") as raised:
        run_sweep(plan, tmp_path / "sweep", jobs=1, progress=False, batch_runs=1)
    saved = len(read_manifest(tmp_path / "sweep" / "manifest.jsonl")[1])
    assert saved == 1 and raised.value.args[0].startswith(f"interrupted: {saved} of 2"), raised.value
