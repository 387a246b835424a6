"""Reliability items of issue 12 done so far: non-finite runs are never ok, sweep names stay plain."""

import dataclasses

import pandas as pd

import numpy as np
import pytest

from liaison_cli.campaign.worker import draw_run_inputs
from liaison_cli.estimation.estimators import estimate
from liaison_cli.scenario.schema import load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS, run_cli


def test_a_non_finite_innovation_ends_the_run_as_diverged():
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    problem = prepare_problem(scenario)
    inputs = draw_run_inputs(problem, 0)
    broken = dataclasses.replace(problem.filter, sigma=np.full_like(problem.filter.sigma, np.inf))
    history = estimate("ekf", broken, inputs.x0_hat, inputs.y_obs, inputs.truth)
    assert not history.ok and "innovation" in history.reason and history.fail_step == 1


@pytest.mark.parametrize("name", ["x/../../victim", "../up", "a/b", ".hidden", "a..b"])
def test_sweep_name_must_be_plain(tmp_path, name):
    proc = run_cli("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100,200", "--runs", "1", "--name", name,
                   "--overwrite", cwd=tmp_path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and "--name" in proc.stderr
    assert list(tmp_path.iterdir()) == []  # nothing written anywhere below the working folder
    assert not (tmp_path.parent / "victim").exists()


def test_wide_numbers_keep_a_space_between_columns():
    import pandas as pd

    from liaison_cli.cli import _format_curve, _format_summary

    summary = pd.DataFrame([{"spacecraft": "EML2", "status": "ok", "rms_position_m": 1361933.5,
                             "rms_position_after_day1_m": 1294688.1, "rms_velocity_m_s": 12345.6,
                             "rms_velocity_after_day1_m_s": 23456.7, "frac_in_2sigma_after_day1": 0.0,
                             "frac_in_3sigma_after_day1": 0.0}])
    row = _format_summary(summary, ["EML2"]).splitlines()[1]
    assert "1361933.5 1294688.1 " in row and "12345600.000 23456700.000" in row
    curve = pd.DataFrame([{"scenario": "a_very_long_scenario", "spacecraft": "spacecraft_x", "noise.sigma_m": 150,
                           "runs_ok": 3, "runs": 41381431, "rms_position_m_mean": 1e7, "rms_position_m_p10": 1e6,
                           "rms_position_m_p90": 1e8, "rms_velocity_m_s_mean": 1e5}])
    row = _format_curve(curve, ["noise.sigma_m"]).splitlines()[1]
    assert row.startswith("a_very_long_scenario spacecraft_x ") and " 3/41381431 " in row


def test_a_corrupt_manifest_line_in_the_middle_drops_only_itself(tmp_path):
    from liaison_cli.campaign.sweep import read_manifest, run_sweep
    from tests.test_sweep import _smoke_plan

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
    proc = run_cli("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", blocker / "out")
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    line = proc.stderr.strip().splitlines()
    assert len(line) == 1 and str(blocker) in line[0] and "Not a directory" in line[0]
    assert blocker.read_text() == "not a folder"


def _sweep_args(out, runs=30, jobs=1):
    return ["sweep", "--scenario", SCENARIOS / "smoke.yaml", "--sigma", "100:300:100", "--grid", "duration_days=4",
            "--runs", str(runs), "--jobs", str(jobs), "--quiet", "--output", out]


def test_a_second_sweep_into_a_busy_folder_is_refused(tmp_path):
    from liaison_cli.campaign.sweep import sweep_lock

    out = tmp_path / "busy"
    with sweep_lock(out):  # another sweep holds the folder
        proc = run_cli(*_sweep_args(out, runs=1))
    assert proc.returncode == 2 and "another liaison sweep" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not out.exists()
    proc = run_cli(*_sweep_args(out, runs=1))  # free again
    assert proc.returncode == 0, proc.stderr


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
    lines = [line for line in stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1 and "interrupted:" in lines[0] and "of 90 tasks saved" in lines[0]
    assert "rerun the same command to resume" in lines[0]
    saved = int(lines[0].split("interrupted: ")[1].split(" of")[0])
    assert saved == manifest.read_bytes().count(b"\n") - 1
    resumed = run_cli(*_sweep_args(out))
    assert resumed.returncode == 0 and f"{90 - saved} computed, {saved} reused" in resumed.stdout


def test_a_killed_overwrite_keeps_the_old_result(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    from tests.conftest import REPO

    out = tmp_path / "result"
    assert run_cli("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", out).returncode == 0
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
    # The rerun replaces it; nothing of the killed run's is left but its hidden staging folder, and a
    # successful run leaves no staging folder of its own.
    assert run_cli("run", SCENARIOS / "smoke.yaml", "--runs", "2", "--output", out, "--overwrite").returncode == 0
    assert (out / ".liaison-result").exists() and len(list(tmp_path.glob(".result.old-*"))) == 0


def test_a_corrupt_curve_given_to_plot_is_one_line_exit_4(tmp_path):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    (sweep / "curve.parquet").write_bytes(b"PAR1" + b"\x00" * 64)
    proc = run_cli("plot", "fig15", sweep)
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(sweep / "curve.parquet") in lines[0] and "not a readable Parquet" in lines[0]


@pytest.mark.parametrize("command", [["run", SCENARIOS / "smoke.yaml"], ["sweep", SCENARIOS / "smoke.yaml",
                                                                         "--sigma", "100"]])
def test_runs_on_the_command_line_obey_the_scenario_cap(tmp_path, command):
    proc = run_cli(*command, "--runs", "10000000", "--output", tmp_path / "o")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--runs 10000000" in proc.stderr and "1,000,000" in proc.stderr and not (tmp_path / "o").exists()
