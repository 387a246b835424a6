"""Compiling ahead on the idle core (campaign.engine.ahead): when the helper starts, what it runs, and that it
ends with the run, whichever way the run ends."""

import os
import pickle
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path
from types import SimpleNamespace

import pytest
from numba.core import event

from liaison_cli.campaign.engine import ahead, warmup
from liaison_cli.campaign.engine.helper_process import helper_command

HERE = Path(__file__).resolve().parent
SCENARIO = SimpleNamespace(estimator="ekf", dynamics="crtbp", name="ahead-test")


def write_name(scenario, path) -> None:
    """A step that records the scenario it was given (imported by name in the helper)."""
    Path(path).write_text(scenario.name)


def fail_loudly() -> None:
    raise RuntimeError("a step that fails")


def write_surroundings(path) -> None:
    """A step that records where the helper's liaison_cli comes from, its truth cache setting and its
    niceness."""
    import liaison_cli

    Path(path).write_text(f"{liaison_cli.__file__}|{os.environ.get('LIAISON_TRUTH_CACHE')}|{os.nice(0)}")


def _compile_event(module: str) -> None:
    """What numba announces when it compiles a function of `module` (a cache miss)."""
    function = SimpleNamespace(__module__=module)
    data = {"dispatcher": SimpleNamespace(py_func=function)}
    event.start_event("numba:compile", data=data)
    event.end_event("numba:compile", data=data)


def _wait_for(predicate, timeout_s: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return False


@pytest.mark.parametrize("jobs, where, estimator", [(1, "joblib", "ekf"), (2, "dask", "ekf"),
                                                     (2, "joblib", "batch")])
def test_no_helper_for_one_job_a_cluster_or_the_batch(jobs, where, estimator):
    scenario = SimpleNamespace(estimator=estimator, dynamics="crtbp", name="x")
    with ahead.compiling_ahead(scenario, jobs, where, steps=[]) as helper:
        _compile_event("liaison_cli.estimation.lincov")
    assert helper is None


def test_no_helper_on_one_core(monkeypatch):
    monkeypatch.setattr(ahead, "usable_cores", lambda: 1)
    with ahead.compiling_ahead(SCENARIO, 2, "joblib", steps=[]) as helper:
        pass
    assert helper is None


def test_the_helper_starts_at_the_first_liaison_compile_runs_its_steps_and_ends_with_the_block(tmp_path):
    marker = tmp_path / "name"
    steps = [(fail_loudly, ()), (write_name, (ahead.SCENARIO, str(marker))), (time.sleep, (60,))]
    with ahead.compiling_ahead(SCENARIO, 2, "joblib", steps=steps) as helper:
        _compile_event("numpy.other")  # not liaison's: a warm cache with someone else compiling starts nothing
        assert not helper.started
        _compile_event("liaison_cli.estimation.lincov")
        assert helper.started
        process = helper.process
        _compile_event("liaison_cli.estimation.ekf")  # once
        assert helper.process is process
        # A step that fails is skipped; the scenario reaches the one that asks for it.
        assert _wait_for(lambda: marker.is_file() and marker.read_text() == "ahead-test")
        assert process.poll() is None  # still in its last step
    assert process.poll() is not None  # stopped with the block, its last step unfinished
    _compile_event("liaison_cli.estimation.lincov")  # the listener went with the block
    assert helper.process is False


def test_an_interrupted_block_stops_the_helper():
    with pytest.raises(KeyboardInterrupt):
        with ahead.compiling_ahead(SCENARIO, 2, "joblib", steps=[(time.sleep, (60,))]) as helper:
            _compile_event("liaison_cli.dynamics.model")
            process = helper.process
            raise KeyboardInterrupt
    assert process.poll() is not None


def test_the_helper_ends_when_the_run_that_started_it_is_killed(tmp_path):
    """A run killed with SIGKILL (no handler runs) leaves no helper compiling for nobody."""
    pid_file = tmp_path / "helper.pid"
    parent = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import time, sys
        sys.path.insert(0, {str(HERE)!r})
        from test_ahead import SCENARIO, _compile_event
        from liaison_cli.campaign.engine import ahead
        with ahead.compiling_ahead(SCENARIO, 2, "joblib", steps=[(time.sleep, (120,))]) as helper:
            _compile_event("liaison_cli.estimation.lincov")
            open({str(pid_file)!r}, "w").write(str(helper.process.pid))
            time.sleep(120)
    """)])
    try:
        assert _wait_for(lambda: pid_file.is_file() and pid_file.read_text().strip())
        helper_pid = int(pid_file.read_text())
        time.sleep(1.0)  # the helper has read its steps and watches its parent
        parent.send_signal(signal.SIGKILL)
        parent.wait()

        def gone() -> bool:
            try:
                os.kill(helper_pid, 0)
            except ProcessLookupError:
                return True
            return Path(f"/proc/{helper_pid}/status").is_file() and "zombie" in Path(
                f"/proc/{helper_pid}/status").read_text()

        assert _wait_for(gone, timeout_s=10.0)
    finally:
        parent.kill()


def test_a_helper_whose_run_is_gone_before_it_starts_does_nothing(tmp_path):
    """A run killed within the helper's first instants: the helper is handed to another parent before it can
    look, so it checks the run's own process id, not whichever parent it has then."""
    marker = tmp_path / "ran"
    command = helper_command()
    command[-1] = "1"  # a process that is not its parent: the run is gone
    helper = subprocess.run(command, input=pickle.dumps((SCENARIO, [(write_name, (ahead.SCENARIO, str(marker)))])),
                            capture_output=True, timeout=60)
    assert helper.returncode == 1 and not marker.exists()


def test_the_helper_runs_the_runs_code_at_a_lower_priority_without_a_truth_cache(tmp_path, monkeypatch):
    """Started in a folder holding another liaison_cli, the helper still imports the run's (its exact import
    path, not the working folder's); the day's truth it flies is not cached; it yields the cores to the run."""
    import liaison_cli

    impostor = tmp_path / "liaison_cli"
    impostor.mkdir()
    (impostor / "__init__.py").write_text("raise SystemExit('another liaison_cli was imported')\n")
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "surroundings"
    with ahead.compiling_ahead(SCENARIO, 2, "joblib", steps=[(write_surroundings, (str(marker),))]) as helper:
        _compile_event("liaison_cli.estimation.lincov")
        assert _wait_for(marker.is_file) and helper.process.wait(timeout=30) == 0
    location, truth_cache, niceness = marker.read_text().split("|")
    assert location == liaison_cli.__file__ and truth_cache == "off"
    assert int(niceness) >= min(19, os.nice(0) + 10)


def test_a_dated_scenario_has_its_propagators_compiled_ahead_too():
    crtbp = [step for step, _ in ahead.steps_for(SCENARIO)]
    dated = [step for step, _ in ahead.steps_for(SimpleNamespace(estimator="ekf", dynamics="ephemeris"))]
    assert crtbp[-2:] == dated[-2:] == [warmup.errors_kernels, warmup.observability_kernels]
    assert len(dated) == len(crtbp) + 1
    assert pickle.loads(pickle.dumps(ahead.steps_for(SCENARIO))) == ahead.steps_for(SCENARIO)


@pytest.mark.slow
def test_from_an_empty_cache_errors_and_observability_after_run_compile_nothing(tmp_path):
    """The user's path: the first-ever `liaison run` of a scenario (about a minute of compiling on 2 cores), then
    `liaison errors` and `liaison observability` on it, which find their code compiled by the helper and announce
    no compiling."""
    from liaison_cli.cli.common import COMPILE_NOTICE

    env = {**os.environ, "LIAISON_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("NUMBA_CACHE_DIR", None)
    scenario = str(Path(ahead.__file__).resolve().parents[2] / "shipped_scenarios" / "eml2_lunar.yaml")

    def liaison(*args):
        quiet = ["--quiet"] if args[0] in ("run", "errors") else []
        return subprocess.run([sys.executable, "-m", "liaison_cli", *args, "--output", str(tmp_path / args[0]),
                               *quiet], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900)

    first = liaison("run", scenario, "--runs", "2")
    assert first.returncode == 0 and COMPILE_NOTICE in first.stderr, first.stderr
    for command in ("errors", "observability"):
        after = liaison(command, scenario)
        assert after.returncode == 0, after.stderr
        assert COMPILE_NOTICE not in after.stderr, (command, after.stderr)
