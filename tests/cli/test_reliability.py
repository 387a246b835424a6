"""Reliability items of issue 12 done so far: non-finite runs are never ok, sweep names stay plain."""

import dataclasses

import pandas as pd

import numpy as np
import pytest

from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.estimation.estimators import estimate
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS, run_cli_in_process, stderr_lines


def test_a_non_finite_innovation_ends_the_run_as_diverged():
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    problem = prepare_problem(scenario)
    inputs = draw_run_inputs(problem, 0)
    broken = dataclasses.replace(problem.filter, sigma=np.full_like(problem.filter.sigma, np.inf))
    history = estimate("ekf", broken, inputs.x0_hat, inputs.y_obs, inputs.truth)
    assert not history.ok and "innovation" in history.reason and history.fail_step == 1


@pytest.mark.parametrize("name", ["x/../../victim", "../up", "a/b", ".hidden", "a..b"])
def test_sweep_name_must_be_plain(tmp_path, monkeypatch, name):
    monkeypatch.chdir(tmp_path)  # refused before any work: in this process, run from tmp_path
    proc = run_cli_in_process("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100,200", "--runs", "1", "--name",
                              name, "--overwrite")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(stderr_lines(proc.stderr)) == 1 and "--name" in proc.stderr
    assert list(tmp_path.iterdir()) == []  # nothing written anywhere below the working folder
    assert not (tmp_path.parent / "victim").exists()


def test_wide_numbers_keep_a_space_between_columns():
    import pandas as pd

    from liaison_cli.cli.sweep import _format_curve
    from liaison_cli.report.run_text import format_summary as _format_summary

    summary = [{"spacecraft": "EML2", "status": "ok", "rms_position_m": 1361933.5,
                "rms_position_after_day1_m": 1294688.1, "rms_velocity_m_s": 12345.6,
                "rms_velocity_after_day1_m_s": 23456.7, "frac_in_2sigma_after_day1": 0.0,
                "frac_in_3sigma_after_day1": 0.0}]
    row = _format_summary(summary, ["EML2"]).splitlines()[1]
    assert "1361933.5 1294688.1 " in row and "12345600.000 23456700.000" in row
    # A scenario of a day or less has no epoch after day 1: its columns say '-', never 'nan'.
    short = [{**summary[0], "rms_position_after_day1_m": float("nan"), "rms_velocity_after_day1_m_s": float("nan"),
              "frac_in_2sigma_after_day1": float("nan"), "frac_in_3sigma_after_day1": float("nan")}]
    header, row = _format_summary(short, ["EML2"]).splitlines()
    assert "nan" not in row and row.split()[1:] == ["1361933.5", "-", "12345600.000", "-", "-", "-"]
    curve = pd.DataFrame([{"scenario": "a_very_long_scenario", "spacecraft": "spacecraft_x", "noise.sigma_m": 150,
                           "runs_ok": 3, "runs": 41381431, "rms_position_m_mean": 1e7, "rms_position_m_p10": 1e6,
                           "rms_position_m_p90": 1e8, "rms_velocity_m_s_mean": 1e5}])
    row = _format_curve(curve, ["noise.sigma_m"]).splitlines()[1]
    assert row.startswith("a_very_long_scenario spacecraft_x ") and " 3/41381431 " in row


def test_a_corrupt_manifest_line_in_the_middle_drops_only_itself(tmp_path):
    from liaison_cli.campaign.sweep.manifest import read_manifest
    from liaison_cli.campaign.sweep.run import run_sweep
    from tests.unit.campaign.test_sweep import _smoke_plan

    plan = _smoke_plan(runs=3)
    full = run_sweep(plan, tmp_path / "s", jobs=1, progress=False)
    manifest = tmp_path / "s" / "manifest.jsonl"
    lines = manifest.read_bytes().splitlines(keepends=True)
    manifest.write_bytes(b"".join(lines[:2]) + b"garbage {\n" + b"".join(lines[3:]))
    _, records, valid = read_manifest(manifest)
    assert len(records) == 5 and valid == manifest.stat().st_size  # the later records survive
    again = run_sweep(plan, tmp_path / "s", jobs=1, progress=False)
    assert (again.computed, again.reused) == (1, 5)
    pd.testing.assert_frame_equal(full.runs_table, again.runs_table)


def test_os_faults_are_one_line_exit_4(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", blocker / "out")
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    line = stderr_lines(proc.stderr)
    assert len(line) == 1 and str(blocker) in line[0] and "Not a directory" in line[0]
    assert blocker.read_text() == "not a folder"


def _sweep_args(out, runs=30, jobs=1):
    return ["sweep", "--scenario", SCENARIOS / "smoke.yaml", "--sigma", "100:300:100", "--grid", "duration_days=4",
            "--runs", str(runs), "--jobs", str(jobs), "--quiet", "--output", out]


def test_a_second_sweep_into_a_busy_folder_is_refused(tmp_path):
    from liaison_cli.campaign.sweep.manifest import sweep_lock

    out = tmp_path / "busy"
    with sweep_lock(out):  # another sweep holds the folder
        proc = run_cli_in_process(*_sweep_args(out, runs=1))
    assert proc.returncode == 2 and "another liaison sweep" in proc.stderr, proc.stderr
    assert len(stderr_lines(proc.stderr)) == 1 and not out.exists()
    proc = run_cli_in_process(*_sweep_args(out, runs=1))  # free again
    assert proc.returncode == 0, proc.stderr
    assert not list(tmp_path.glob(".*.lock")), "a finished sweep leaves no lock file (issue 47)"


def test_run_overwrite_leaves_a_folder_a_sweep_is_writing(tmp_path):
    """Issue 47: `run --overwrite` replaced the folder a running sweep wrote into (the sweep then died with a
    traceback and lost its finished tasks). The replacement takes the sweep's lock: refused in one line, before
    any work, the folder untouched; once the sweep is done, the same command replaces it."""
    from liaison_cli.campaign.sweep.manifest import sweep_lock
    from liaison_cli.storage.ownership import mark_ours

    out = tmp_path / "busy"
    out.mkdir()
    mark_ours(out)  # a sweep's folder, as liaison marks it
    (out / "manifest.jsonl").write_text("{}\n")
    args = ["run", SCENARIOS / "smoke.yaml", "--runs", "1", "--jobs", "1", "--output", out, "--overwrite"]
    with sweep_lock(out):
        proc = run_cli_in_process(*args)
    assert proc.returncode == 2 and "a sweep) is writing into this folder" in proc.stderr, proc.stderr
    assert len(stderr_lines(proc.stderr)) == 1
    before = sorted(p.name for p in out.iterdir())
    assert "manifest.jsonl" in before and not list(tmp_path.glob(".busy.partial-*"))


def test_the_lock_file_is_removed_by_its_holder_and_a_stale_handle_locks_again(tmp_path):
    """A process that opened the lock file just before its holder removed it locks a removed inode: it must
    see another file at the path and lock that one, or two sweeps would both hold 'the' lock."""
    import fcntl
    import os

    from liaison_cli.campaign.sweep.manifest import sweep_lock

    out = tmp_path / "folder"
    with sweep_lock(out):
        stale = open(tmp_path / ".folder.lock", "a")  # opened while held, as a second process might
    assert not (tmp_path / ".folder.lock").exists()
    fcntl.flock(stale.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)  # it can lock the removed inode ...
    with sweep_lock(out):  # ... but a new sweep locks the file at the path, which the stale handle is not
        assert os.fstat(stale.fileno()).st_ino != os.stat(tmp_path / ".folder.lock").st_ino
    stale.close()


@pytest.mark.parametrize("jobs", [1, 2])
def test_ctrl_c_saves_what_finished_and_says_how_to_resume(tmp_path, jobs):
    import os
    import signal
    import subprocess
    import sys
    import time

    from tests.conftest import REPO

    out = tmp_path / "interrupted"
    # A shell that starts the tests in the background hands its children SIGINT ignored; a user's terminal
    # does not: restore the default so the child sees Ctrl-C as a user would.
    # Its own process group, as a terminal would have: Ctrl-C reaches the CLI and its workers alike.
    proc = subprocess.Popen([sys.executable, "-m", "liaison_cli", *map(str, _sweep_args(out, jobs=jobs))],
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL), start_new_session=True)
    manifest = out / "manifest.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if manifest.exists() and manifest.read_bytes().count(b"\n") >= 11:
            break
        time.sleep(0.005)
    assert proc.poll() is None, "the sweep finished before it could be interrupted"
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "Traceback" not in stderr, stderr
    lines = stderr_lines(stderr)
    assert len(lines) == 1 and "interrupted:" in lines[0] and "of 90 tasks saved" in lines[0]
    assert "rerun the same command to resume" in lines[0]
    saved = int(lines[0].split("interrupted: ")[1].split(" of")[0])
    assert saved == manifest.read_bytes().count(b"\n") - 1
    resumed = run_cli_in_process(*_sweep_args(out))
    assert resumed.returncode == 0 and f"{90 - saved} computed, {saved} reused" in resumed.stdout


def test_a_killed_overwrite_keeps_the_old_result(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    from tests.conftest import REPO

    out = tmp_path / "result"
    assert run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", out).returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    proc = subprocess.Popen([sys.executable, "-m", "liaison_cli", "run", str(SCENARIOS / "eml2_lunar.yaml"),
                             "--runs", "200", "--jobs", "1", "--output", str(out), "--overwrite"], cwd=REPO,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list(tmp_path.glob(".result.partial-*")):
        time.sleep(0.01)
    time.sleep(1.0)  # well into the computation
    assert proc.poll() is None
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # the old result is intact
    # The rerun replaces it and removes the killed run's hidden staging folder (issue 24); a successful run
    # leaves no staging folder of its own.
    assert run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "2", "--output", out, "--overwrite").returncode == 0
    assert (out / ".liaison-result").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["result"]


def test_a_corrupt_curve_given_to_plot_is_one_line_exit_4(tmp_path):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    (sweep / "curve.parquet").write_bytes(b"PAR1" + b"\x00" * 64)
    proc = run_cli_in_process("plot", "fig15", sweep)
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    lines = stderr_lines(proc.stderr)
    assert len(lines) == 1 and str(sweep / "curve.parquet") in lines[0] and "not a readable Parquet" in lines[0]


@pytest.mark.parametrize("command", [["run", SCENARIOS / "smoke.yaml"], ["sweep", SCENARIOS / "smoke.yaml",
                                                                         "--sigma", "100"]])
def test_runs_on_the_command_line_obey_the_scenario_cap(tmp_path, command):
    proc = run_cli_in_process(*command, "--runs", "10000000", "--output", tmp_path / "o")
    assert proc.returncode == 2 and len(stderr_lines(proc.stderr)) == 1, proc.stderr
    assert "--runs 10000000" in proc.stderr and "1,000,000" in proc.stderr and not (tmp_path / "o").exists()


def test_streamed_tables_equal_the_in_memory_tables(tmp_path):
    """`liaison run` writes its tables while runs arrive, in row groups; the values are those of the tables
    built from every outcome held in memory."""
    import pyarrow.parquet as pq

    from liaison_cli.campaign.engine import results
    from liaison_cli.campaign.engine.runner import run_campaign

    scenario, text = load_scenario(SCENARIOS / "clock_one_way_eml2_lunar.yaml")
    scenario = scenario.model_copy(update={"duration_days": 0.3})
    held = run_campaign(scenario, runs=4, jobs=1, progress=False)
    results.write_campaign(held, tmp_path / "held", text)
    results.write_outcomes(held.problem, iter(held.outcomes), 4, tmp_path / "streamed", text, flush_rows=300)
    for name in ("summary", "timeseries", "residuals", "consistency", "bias", "clocks"):
        pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "streamed" / f"{name}.parquet"),
                                      pd.read_parquet(tmp_path / "held" / f"{name}.parquet"), check_exact=True)
    assert pq.ParquetFile(tmp_path / "streamed" / "residuals.parquet").num_row_groups > 1
    assert not list((tmp_path / "streamed").glob(".*.tmp"))


def test_the_writer_holds_a_bounded_number_of_outcomes(tmp_path):
    """Memory does not grow with the run count: the writer lets each outcome go once its rows are buffered."""
    import weakref

    from liaison_cli.campaign.engine import results
    from liaison_cli.campaign.engine.worker import RunTask, execute_run

    scenario, text = load_scenario(SCENARIOS / "smoke.yaml")
    scenario = scenario.model_copy(update={"duration_days": 0.2})
    problem = prepare_problem(scenario)
    alive, most_alive = set(), [0]

    def outcomes(n_runs):
        for run in range(n_runs):
            outcome = execute_run(problem, RunTask(run))
            alive.add(run)
            weakref.finalize(outcome, alive.discard, run)
            most_alive[0] = max(most_alive[0], len(alive))
            yield outcome
            del outcome

    summary = results.write_outcomes(problem, outcomes(40), 40, tmp_path, text, flush_rows=100)
    assert len(summary) == 40 * 2 and {row["status"] for row in summary} == {"ok"}
    assert most_alive[0] <= 2
    assert pd.read_parquet(tmp_path / "timeseries.parquet").run.nunique() == 40


def test_a_run_that_loses_track_is_diverged_by_the_nees_rule(tmp_path):
    """An ignored 20 km range bias: no position error reaches the 10,000 km bound, yet the filter's errors
    are tens of sigmas out for days (NEES about 4,000 x its 99.9 % quantile). The NEES rule (100 x the 99.9 %
    chi-square quantile for a whole day) calls it diverged; the same filter with the bias estimated stays ok,
    and so does an ignored 3-sigma bias (test_bias: NEES up to about 11 x the quantile)."""
    from liaison_cli.campaign.engine.runner import run_campaign
    from liaison_cli.scenario.loading import apply_overrides

    base, _ = load_scenario(SCENARIOS / "smoke.yaml")
    ignored = apply_overrides(base, {"noise.bias_m": 20_000.0, "duration_days": 2.5}, "test")
    lost = run_campaign(ignored, runs=2, jobs=1, progress=False).outcomes
    assert [o.status for o in lost] == ["diverged", "diverged"]
    assert "NEES above 3291 (100 x the 99.9 % chi-square quantile of 12 states) for 1 d" in lost[0].reason
    day_s = 86400.0
    assert day_s < lost[0].fail_time_s < 2.5 * day_s
    assert max(float(np.max(o.norms["position_error_m"])) for o in lost) < 1e7  # the old bound never tripped
    estimated = apply_overrides(ignored, {"filter.bias": "estimate", "filter.bias_apriori_sigma_m": 30_000.0},
                                "test")
    assert [o.status for o in run_campaign(estimated, runs=2, jobs=1, progress=False).outcomes] == ["ok", "ok"]
    strict = apply_overrides(base, {"filter.divergence_nees_factor": 1.0, "filter.divergence_window_days": 0.01,
                                    "filter.range_model": "geometric"}, "test")  # the paper's mismatched model
    assert {o.status for o in run_campaign(strict, runs=2, jobs=1, progress=False).outcomes} == {"diverged"}


def test_a_sweep_where_every_run_diverged_exits_5_and_keeps_its_results(tmp_path):
    from tests.conftest import edited_scenario

    lost = edited_scenario(tmp_path, "smoke.yaml", "  sigma_m: 150\n", "  sigma_m: 150\n  bias_m: 20000\n")
    lost.write_text(lost.read_text().replace("duration_days: 1.25", "duration_days: 2.5"))
    out = tmp_path / "sweep"
    done = run_cli_in_process("sweep", lost, "--sigma", "100,200", "--runs", "2", "--jobs", "1", "--output", out, "--quiet")
    assert done.returncode == 5, done.stderr
    lines = stderr_lines(done.stderr)
    assert len(lines) == 1 and lines[0].startswith("error: no run of sweep") and str(out) in lines[0]
    assert "4 spacecraft-runs" not in done.stdout and "8 spacecraft-runs diverged" in done.stdout
    assert (out / "curve.parquet").exists() and (out / "runs.parquet").exists()
    run = run_cli_in_process("run", lost, "--runs", "2", "--jobs", "1", "--output", tmp_path / "run", "--quiet")
    assert run.returncode == 5 and "0/2 runs ok" in run.stdout and "NEES above" in run.stdout


def test_sweep_overwrite_builds_beside_the_old_result_and_resumes_there(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    from tests.conftest import REPO

    out = tmp_path / "sweep"
    assert run_cli_in_process("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100", "--runs", "1", "--jobs", "1",
                   "--output", out, "--quiet").returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    command = ["sweep", str(SCENARIOS / "eml2_lunar.yaml"), "--sigma", "100,200", "--runs", "40", "--jobs", "1",
               "--output", str(out), "--overwrite", "--quiet"]
    proc = subprocess.Popen([sys.executable, "-m", "liaison_cli", *command], cwd=REPO,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    manifests = []
    while time.monotonic() < deadline and proc.poll() is None:
        manifests = list(tmp_path.glob(".sweep.replacing-*/manifest.jsonl"))
        if manifests and len(manifests[0].read_text().splitlines()) >= 3:  # header + two batches
            break
        time.sleep(0.05)
    assert proc.poll() is None, "the sweep finished before it could be stopped"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # the old result is intact
    done = run_cli_in_process(*command)
    assert done.returncode == 0, done.stderr
    assert "reused from the manifest" in done.stdout and ", 0 reused" not in done.stdout
    assert not list(tmp_path.glob(".sweep.replacing-*")) and not list(tmp_path.glob(".sweep.old-*"))
    assert len(pd.read_parquet(out / "runs.parquet").query("spacecraft == 'EML2'")) == 80


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs. Mounting needs root; elsewhere the test is skipped and the injected-fault test below
    stands in for it."""
    import os
    import subprocess

    disk = tmp_path / "disk"
    disk.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(disk)],
                                           capture_output=True).returncode != 0:
        pytest.skip("mounting a tmpfs needs root")
    yield disk
    subprocess.run(["umount", "-l", str(disk)], capture_output=True)


def _fill(disk, leave_bytes):
    import os

    stats = os.statvfs(disk)
    (disk / "filler").write_bytes(b"\0" * max(0, stats.f_bavail * stats.f_frsize - leave_bytes))


def test_a_full_disk_is_one_line_and_leaves_nothing_that_blocks_a_rerun(small_disk):
    out = small_disk / "out"
    proc = run_cli_in_process("run", SCENARIOS / "eml2_lunar.yaml", "--runs", "10", "--output", out, "--quiet")
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    lines = stderr_lines(proc.stderr)
    assert len(lines) == 1 and str(out) in lines[0] and "No space left on device" in lines[0]
    assert list(small_disk.iterdir()) == []  # no partial folder, no temp file
    assert run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", out, "--quiet").returncode == 0
    # A sweep that meets a full disk keeps its manifest and resumes once there is room.
    sweep = small_disk / "sweep"
    _fill(small_disk, 32768)  # room for the header and a few records (each about 5 kB), not for all
    args = ["sweep", SCENARIOS / "smoke.yaml", "--sigma", "100:700:100", "--runs", "4", "--jobs", "1",
            "--output", sweep, "--quiet"]
    proc = run_cli_in_process(*args)
    assert proc.returncode == 4 and "No space left on device" in proc.stderr and str(sweep) in proc.stderr
    assert len(stderr_lines(proc.stderr)) == 1
    (small_disk / "filler").unlink()
    proc = run_cli_in_process(*args)
    assert proc.returncode == 0, proc.stderr
    assert "reused from the manifest" in proc.stdout and ", 0 reused" not in proc.stdout
    assert len(pd.read_parquet(sweep / "runs.parquet")) == 7 * 4 * 2


def test_a_read_only_file_system_is_one_line_and_the_old_result_stays(small_disk):
    import subprocess

    out = small_disk / "out"
    assert run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", out, "--quiet").returncode == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], check=True)
    for args, named in ((["run", SCENARIOS / "smoke.yaml", "--output", out, "--overwrite"], out),
                        (["run", SCENARIOS / "smoke.yaml", "--output", small_disk / "new"], small_disk / "new"),
                        (["sweep", SCENARIOS / "smoke.yaml", "--sigma", "100", "--output", small_disk / "sw"],
                         small_disk)):
        proc = run_cli_in_process(*args, "--runs", "1", "--quiet")
        assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
        lines = stderr_lines(proc.stderr)
        assert len(lines) == 1 and str(named) in lines[0] and "Read-only file system" in lines[0]
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_an_injected_disk_full_fault_names_the_file(tmp_path, monkeypatch):
    """Without root (no tmpfs), the same fault injected where pyarrow writes: one line, exit 4, the path,
    and no partial folder left."""
    import pyarrow.parquet as pq
    from typer.testing import CliRunner

    from liaison_cli.cli import app

    def full(self, *args, **kwargs):
        raise OSError("Error writing bytes to file. Detail: [errno 28] No space left on device")

    monkeypatch.setattr(pq.ParquetWriter, "write_table", full)
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["run", str(SCENARIOS / "smoke.yaml"), "--runs", "1", "--jobs", "1",
                                      "--output", str(out), "--quiet"])
    assert result.exit_code == 4, result.output
    assert f"{out}/timeseries.parquet: No space left on device" in result.output
    assert list(tmp_path.iterdir()) == []


def test_no_permission_is_one_line_exit_4(tmp_path, monkeypatch):
    """EACCES (injected: the tests may run as root, whom permissions do not stop) names the result folder."""
    import errno
    import os
    import tempfile

    from typer.testing import CliRunner

    from liaison_cli.cli import app

    def refused(*args, dir=None, **kwargs):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(dir))

    monkeypatch.setattr(tempfile, "mkdtemp", refused)
    out = tmp_path / "locked" / "out"
    result = CliRunner().invoke(app, ["run", str(SCENARIOS / "smoke.yaml"), "--runs", "1", "--output", str(out)])
    assert result.exit_code == 4, result.output
    assert result.output.strip() == f"error: {out}: Permission denied"


def test_a_rerun_keeps_what_other_commands_wrote_into_the_result(tmp_path):
    """Issue 47: a second `liaison run` removed the plots and CCSDS files other commands had written into the
    result folder. It replaces only what it writes again; the rest is kept, with one note naming it."""
    out = tmp_path / "result"
    args = ("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--jobs", "1", "--quiet", "--output", out)
    assert run_cli_in_process(*args).returncode == 0
    (out / "plots").mkdir()
    (out / "plots" / "errors.png").write_bytes(b"a figure")
    (out / "ccsds-run0").mkdir()
    (out / "ccsds-run0" / "truth.oem").write_text("an export")
    (out / "notes.txt").write_text("mine")
    before = (out / "summary.parquet").stat().st_mtime_ns
    proc = run_cli_in_process(*args, "--overwrite")
    assert proc.returncode == 0, proc.stderr
    assert (out / "plots" / "errors.png").read_bytes() == b"a figure"
    assert (out / "ccsds-run0" / "truth.oem").read_text() == "an export"
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "summary.parquet").stat().st_mtime_ns != before  # the run's own tables are the new ones
    notes = [line for line in proc.stderr.splitlines() if "kept from the result it replaced" in line]
    assert len(notes) == 1 and "ccsds-run0/, notes.txt, plots/" in notes[0], proc.stderr
    assert not list(tmp_path.glob(".result.*")), "no staging folder left beside it"
