"""Ctrl-C at the moments issue 35 found it lost or turned into a traceback, each made deterministic:

- while the joblib (loky) pool starts its workers: SIGINT was ignored in the whole process for the launch, so a
  Ctrl-C then was dropped, the command ran to its end, exit 0, and replaced the earlier result (fault 7);
- in a dask sweep: the LocalCluster's workers took the terminal's SIGINT too and died mid-task, and the sweep
  ended in a FuturesCancelledError traceback, exit 1 (fault 8);
- after the command finished, while the process winds down: death by SIGINT without the promised line
  (fault 12).
"""

import os
import signal
import subprocess
import sys
import time

import pytest

from tests.conftest import REPO, SCENARIOS, run_cli_in_process, stderr_lines

# The CLI's entry point in a fresh interpreter, after `PATCH` (a few lines of Python run first).
CLI_WITH = """
import os, signal, sys, time
{patch}
from liaison_cli.cli import main
sys.argv = ["liaison", *sys.argv[1:]]
main()
"""

# loky's process launcher sends this process a SIGINT the first time it starts a worker, then takes 0.3 s: a
# Ctrl-C that lands while the pool starts, every time.
CTRL_C_WHILE_THE_POOL_STARTS = """
from joblib.externals.loky.backend import fork_exec as launcher
original = launcher.fork_exec
def launch_after_ctrl_c(*args, **kwargs):
    if not getattr(launch_after_ctrl_c, "sent", False):
        launch_after_ctrl_c.sent = True
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.3)
    return original(*args, **kwargs)
launcher.fork_exec = launch_after_ctrl_c
"""

# An exit handler registered first runs last: a Ctrl-C after the command's output and result, while the process
# winds down.
CTRL_C_WHILE_WINDING_DOWN = """
import atexit
def ctrl_c_at_exit():
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.3)
atexit.register(ctrl_c_at_exit)
"""


def _start(args, patch=""):
    """The CLI in its own process group with SIGINT at its default, as a terminal starts it."""
    code = CLI_WITH.format(patch=patch)
    return subprocess.Popen([sys.executable, "-c", code, *map(str, args)], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _one_line(proc, timeout_s=180):
    stdout, stderr = proc.communicate(timeout=timeout_s)
    assert proc.returncode == 130 and "Traceback" not in stderr, (proc.returncode, stderr)
    lines = stderr_lines(stderr)
    assert len(lines) == 1 and lines[0].startswith("error: interrupted"), stderr
    return stdout, lines[0]


@pytest.fixture
def earlier_result(tmp_path):
    out = tmp_path / "result"
    assert run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", out).returncode == 0
    return out, {p.name: p.read_bytes() for p in out.iterdir()}


def test_ctrl_c_while_the_pool_starts_stops_the_run_and_keeps_the_earlier_result(earlier_result):
    """200 runs of eml2_lunar on 2 jobs use the pool (above the in-process threshold); the Ctrl-C comes inside
    the launch of its first worker. Before the fix: exit 0, the earlier result replaced."""
    out, before = earlier_result
    proc = _start(["run", SCENARIOS / "eml2_lunar.yaml", "--runs", "200", "--jobs", "2", "--output", out,
                   "--overwrite", "--quiet"], CTRL_C_WHILE_THE_POOL_STARTS)
    stdout, line = _one_line(proc)
    assert line.startswith("error: interrupted: nothing was written") and "results:" not in stdout
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_ctrl_c_while_winding_down_says_the_result_is_complete(tmp_path):
    """The run printed its summary and wrote its result; a Ctrl-C while the process winds down is one line
    saying so, exit 130 (before: death by SIGINT, no line)."""
    out = tmp_path / "result"
    proc = _start(["run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", out, "--quiet"],
                  CTRL_C_WHILE_WINDING_DOWN)
    stdout, line = _one_line(proc)
    assert "results:" in stdout and (out / "summary.parquet").is_file()
    assert line == f"error: interrupted after the result was written: {out} is complete, and so is the output above"


def _records(manifest) -> int:
    try:
        return max(len(manifest.read_text().splitlines()) - 1, 0)  # the header, then one line per task
    except FileNotFoundError:
        return 0


def test_ctrl_c_in_a_dask_sweep_is_the_same_one_line_as_joblibs(tmp_path):
    """A LocalCluster sweep signalled (the whole process group, as a terminal does) once its first batch is
    saved: the workers, started with SIGINT blocked, keep computing until the sweep stops them; exit 130 with
    the sweep's one line, and the manifest holds what it says. Before: a FuturesCancelledError traceback, exit 1."""
    out = tmp_path / "sweep"
    proc = _start(["sweep", SCENARIOS / "eml2_lunar.yaml", "--sigma", "100,200,300", "--runs", "200", "--backend",
                   "dask", "--jobs", "2", "--output", out, "--quiet"])
    deadline = time.monotonic() + 150
    while time.monotonic() < deadline and proc.poll() is None and not _records(out / "manifest.jsonl"):
        time.sleep(0.05)
    assert proc.poll() is None, "the sweep ended before it could be interrupted"
    os.killpg(proc.pid, signal.SIGINT)
    _, line = _one_line(proc)
    saved = _records(out / "manifest.jsonl")
    assert line.startswith(f"error: interrupted: {saved} of 600 tasks saved in ") and 0 < saved < 600, line


def test_a_dask_fan_out_closes_its_cluster_before_handing_over_the_last_result(monkeypatch):
    """Closing a LocalCluster takes about a second; a sweep checks for Ctrl-C after each batch, so the close must
    come before the last batch is handed over, not after the loop (where a Ctrl-C was noted and never acted on:
    exit 0). A stand-in client runs the batches on threads."""
    import operator
    from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait

    import distributed

    from liaison_cli.campaign.engine import backends

    events, pool = [], ThreadPoolExecutor(2)

    class Future:
        def __init__(self, inner):
            self.inner = inner

        def done(self):
            return self.inner.done()

        def result(self):
            return self.inner.result()

        def release(self):
            pass

    class Client:
        def nthreads(self):
            return {"a": 1, "b": 1}

        def scatter(self, value, broadcast):
            return value

        def submit(self, fn, shared, tasks, pure):
            return Future(pool.submit(fn, shared, tasks))

    monkeypatch.setattr(backends, "_dask_client", lambda jobs, where: (Client(), None))
    monkeypatch.setattr(backends, "_close", lambda client, cluster: events.append("closed"))
    monkeypatch.setattr(distributed, "wait", lambda futures, return_when: wait([f.inner for f in futures],
                                                                              return_when=FIRST_COMPLETED))
    for ordered in (False, True):
        events.clear()
        batches = ((0, index) for index in range(25))
        for value in backends.map_batches(operator.add, {0: 1000}, batches, backends.Backend("dask"), jobs=2,
                                          ordered=ordered):
            events.append(value)
        assert events.count("closed") == 1 and events[-2] == "closed", events
        assert sorted(v for v in events if v != "closed") == [1000 + index for index in range(25)]
    pool.shutdown()
