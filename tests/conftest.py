import contextlib
import signal
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"


def _lunar_orbiter():
    from liaison_cli.orbits.keplerian import lunar_orbiter_state_lu

    return lunar_orbiter_state_lu(9000.0, 0.4, 60.0, 0.0, 0.0, 0.0)


LUNAR = _lunar_orbiter()  # Turan et al.'s lunar orbiter (a 9,000 km, e 0.4, i 60 deg), rotating frame, LU / VU


@pytest.fixture
def scenarios_dir():
    return SCENARIOS


def run_cli(*args, cwd=None):
    """Run the installed CLI in a subprocess (real exit code, real stderr)."""
    import subprocess

    return subprocess.run(
        [sys.executable, "-m", "liaison_cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd or REPO,
        timeout=600,
    )


def run_cli_in_process(*args):
    """The CLI in this process (typer's CliRunner): the same parsing and `user_errors` mapping as run_cli,
    without a new interpreter and its imports (about 1.2 s of CPU a launch): refusals and whole campaigns
    alike, the process pool and dask included. What needs a real process (a signal, an exit code by signal,
    a fresh import state) keeps run_cli or starts its own. An exception other than the exit is raised: a
    traceback the user would see."""
    from types import SimpleNamespace

    from typer.testing import CliRunner

    from liaison_cli.cli import app

    with contextlib.chdir(REPO):  # as run_cli: relative paths and defaults (results/) from the repository
        result = CliRunner().invoke(app, [str(a) for a in args])
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return SimpleNamespace(returncode=result.exit_code, stderr=result.stderr, stdout=result.stdout)


def edited_scenario(tmp_path, source_name: str, old: str, new: str) -> Path:
    """A copy of scenarios/<source_name> with one text edit (the edit must apply)."""
    text = (SCENARIOS / source_name).read_text()
    assert old in text, old
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(old, new))
    return path


def stderr_lines(stderr: str) -> list[str]:
    """stderr's non-blank lines, less the cold-cache compile note (cli.common.COMPILE_NOTICE): whichever process
    first compiles a kernel prints it, and on a cold cache that can be any CLI run of the suite."""
    from liaison_cli.cli.common import COMPILE_NOTICE

    return [line for line in stderr.strip().splitlines() if line.strip() and line != f"note: {COMPILE_NOTICE}"]


def assert_one_line_error(proc, path, fragments, code: int = 2) -> None:
    """Exit code, no traceback, one line naming the file and containing every fragment."""
    assert proc.returncode == code and "Traceback" not in proc.stderr, proc.stderr
    lines = stderr_lines(proc.stderr)
    assert len(lines) == 1 and str(path) in lines[0], proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.fixture(autouse=True)
def signals_kept():
    """A CLI run in this process installs its SIGINT and SIGTERM handlers and, once interrupted, ignores both:
    the test process's own dispositions are put back after every test. Left ignored, they were inherited by
    every process a later test starts (a disposition of SIG_IGN survives fork and exec), and that test's
    `kill PID` reached a CLI that ignored it: exit 0 where 130 was right, depending on the order tests ran in."""
    previous = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    yield
    for number, handler in previous.items():
        if handler is not None:
            signal.signal(number, handler)


@pytest.fixture
def sigint_kept(signals_kept):
    """Kept for the tests that name it: every test now has signals_kept."""
    yield



def _core_cached() -> bool:
    """Whether the compiled-code cache holds the estimators every test process would otherwise compile at once
    (the EKF, LinCov, the batch): their cache index files exist."""
    import liaison_cli

    folder = Path(liaison_cli._numba_cache_dir()) / "liaison_cli" / "estimation"
    return all(any(folder.glob(pattern)) for pattern in ("filter_loop.run_ekf-*.nbi", "lincov.lincov_along_truth-*.nbi",
                                                          "batch.accumulate_normal_equations-*.nbi"))


def pytest_sessionstart(session):
    """On a cold compiled-code cache, `liaison warm-up` once, before the test processes start: each estimator is
    one compiled body for every scenario, and test processes that all met it at once compiled it side by side
    (a cold suite took 7:18 instead of 4:30 on 2 cores). The controller only (an xdist worker finds the cache
    filled); nothing when the cache holds the core already, with one test process (`-n 0`) or with
    LIAISON_TEST_NO_WARM_UP set."""
    import os
    import subprocess
    import time

    config = session.config
    workers = config.getoption("numprocesses", None) or 0
    if (hasattr(config, "workerinput") or config.getoption("collectonly") or os.environ.get("LIAISON_TEST_NO_WARM_UP")
            or (isinstance(workers, int) and workers < 2) or _core_cached()):
        return  # a worker, a listing, the opt-out, one test process (nothing side by side) or a warm cache
    started = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-m", "liaison_cli", "warm-up", "--jobs",
                               str(min(os.cpu_count() or 1, 2))], capture_output=True, text=True, cwd=REPO,
                              timeout=900)
    except subprocess.TimeoutExpired:
        proc = subprocess.CompletedProcess([], -1, "", "timed out after 900 s")
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    line = (f"compiled-code cache was cold: `liaison warm-up` filled it in {time.perf_counter() - started:.0f} s"
            if proc.returncode == 0 else f"`liaison warm-up` failed ({proc.returncode}); each test compiles what it "
            f"needs: {proc.stderr.strip()[-300:]}")
    if reporter is not None:
        reporter.write_line(line)
