"""Sweeps: grid parsing, kill-and-resume, identical results across backends, failures as data, bad grids."""

import json
import os
import signal
import subprocess
import sys
import time

import pandas as pd
import pytest

from liaison_cli.campaign.sweep.grid import GridError, parse_grid, parse_range
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.campaign.sweep.manifest import read_manifest
from liaison_cli.campaign.sweep.plan import SweepError, plan_sweep
from liaison_cli.campaign.sweep.run import run_sweep
from tests.conftest import REPO, SCENARIOS, run_cli, run_cli_in_process


def test_range_syntax():
    assert parse_range("50:700") == list(range(50, 701, 50))
    assert len(parse_range("50:700")) == 14
    assert parse_range("50:200:75") == [50, 125, 200]
    assert parse_range("0.5:1.0:0.25") == [0.5, 0.75, 1]
    assert parse_range("150, 300") == [150, 300]
    for bad in ("50:", "a:700", "700:50", "50:700:0", "50:700:50:1", "", "50,,"):
        with pytest.raises(GridError):
            parse_range(bad)


def test_grid_syntax():
    assert parse_grid("measurement.interval_s=60,187.5,600") == ("measurement.interval_s", [60, 187.5, 600])
    assert parse_grid("measurement.light_time=true,false") == ("measurement.light_time", [True, False])
    assert parse_grid("noise.sigma_m=100:300:100") == ("noise.sigma_m", [100, 200, 300])
    # Issue 35: 6e-5 is a number, as in a scenario file (YAML 1.1 read it as text), and 6e-5 = 6.0e-5.
    assert parse_grid("noise.range_rate_sigma_m_s=6e-5,4.243e-5,3e-5") == ("noise.range_rate_sigma_m_s",
                                                                           [6e-5, 4.243e-5, 3e-5])
    assert parse_grid("noise.range_rate_sigma_m_s=6.0e-5")[1] == parse_grid("noise.range_rate_sigma_m_s=6e-5")[1]
    for bad in ("noise.sigma_m", "=1,2", "noise.sigma_m=", "noise.sigma_m=1,1", "noise.sigma_m=1e2,100.0"):
        with pytest.raises(GridError):
            parse_grid(bad)


def _smoke_plan(runs=3, sigmas=(100, 300), name="t", extra=()):
    scenario, text = load_scenario(SCENARIOS / "smoke.yaml")
    return plan_sweep([(scenario, text, "smoke.yaml")], [("noise.sigma_m", list(sigmas)), *extra], runs, name)


def test_task_ids_are_stable_and_distinct():
    a, b = _smoke_plan(), _smoke_plan()
    assert [t.task_id for t in a.tasks] == [t.task_id for t in b.tasks]
    assert len({t.task_id for t in a.tasks}) == len(a.tasks) == 6
    with pytest.raises(SweepError, match="same scenario"):
        _smoke_plan(sigmas=(150, 150.0))


def test_sigma_replaces_a_link_budget_noise_model(tmp_path):
    text = (SCENARIOS / "smoke.yaml").read_text().replace(
        "noise:\n  sigma_m: 150\n",
        "noise:\n  ranging_method: time_derived\n  link_budget:\n"
        "    uplink: {distance_km: 60000, frequency_mhz: 2200, tx_power_dbw: 3, tx_losses_db: 1,"
        " tx_antenna_gain_dbi: 25, data_rate_bps: 2000, rx_losses_db: 1, rx_g_over_t_db_k: -21, margin_db: 3}\n"
        "    downlink: {distance_km: 60000, frequency_mhz: 2200, tx_power_dbw: 3, tx_losses_db: 1,"
        " tx_antenna_gain_dbi: 9, data_rate_bps: 5000, rx_losses_db: 1, rx_g_over_t_db_k: -1, margin_db: 3}\n",
    )
    path = tmp_path / "budget.yaml"
    path.write_text(text)
    scenario, text = load_scenario(path)
    assert scenario.noise.resolved_sigma_m() == pytest.approx(172.0, rel=0.02)
    plan = plan_sweep([(scenario, text, str(path))], [("noise.sigma_m", [50, 700])], 1, "b")
    assert [p.sigma_m for p in plan.points] == [50, 700]


def test_backends_give_identical_bytes(tmp_path):
    """joblib 1 worker, joblib 2 workers, and dask: a LocalCluster started here and reached through its
    scheduler address (as a user reaches a remote cluster) -> byte-identical Parquet."""
    distributed = pytest.importorskip("distributed")
    plan = _smoke_plan(runs=4, sigmas=(100, 200, 300))
    outputs = {}
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        runs = {"serial": dict(jobs=1), "joblib2": dict(jobs=2),
                "dask": dict(backend="dask", scheduler=cluster.scheduler_address)}
        for label, kwargs in runs.items():
            result = run_sweep(plan, tmp_path / label, progress=False, batch_runs=3, **kwargs)
            assert result.computed == 12 and result.reused == 0
            outputs[label] = {name: (tmp_path / label / f"{name}.parquet").read_bytes() for name in ("runs", "curve")}
    assert outputs["serial"] == outputs["joblib2"] == outputs["dask"]
    curve = pd.read_parquet(tmp_path / "serial" / "curve.parquet")
    assert list(curve.columns[:4]) == ["point", "scenario", "noise.sigma_m", "sigma_m"]
    assert (curve.runs_ok == 4).all()
    assert (curve.rms_position_m_p10 <= curve.rms_position_m_median).all()
    assert (curve.rms_position_m_median <= curve.rms_position_m_p90).all()


def test_unreachable_scheduler_is_one_line_exit_3(tmp_path):
    pytest.importorskip("distributed")
    proc = run_cli("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100", "--runs", "1", "--backend", "dask",
                   "--scheduler", "tcp://127.0.0.1:9", "--scheduler-timeout", "2", "--quiet", "--output", tmp_path / "o")
    assert proc.returncode == 3 and "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "tcp://127.0.0.1:9" in lines[0] and "cannot connect" in lines[0], proc.stderr


def test_resume_after_torn_manifest_line_recomputes_only_missing(tmp_path):
    plan = _smoke_plan(runs=3)
    full = run_sweep(plan, tmp_path / "full", jobs=1, progress=False, batch_runs=2)
    manifest = tmp_path / "full" / "manifest.jsonl"
    lines = manifest.read_bytes().splitlines(keepends=True)
    # Keep the header and two tasks, then half of the next line (as if killed mid-write).
    manifest.write_bytes(b"".join(lines[:3]) + lines[3][:25])
    header, records, _ = read_manifest(manifest)
    assert header["kind"] == "header" and len(records) == 2
    again = run_sweep(plan, tmp_path / "full", jobs=1, progress=False, batch_runs=2)
    assert (again.computed, again.reused) == (4, 2)
    pd.testing.assert_frame_equal(full.runs_table, again.runs_table)
    assert len(manifest.read_bytes().splitlines()) == 1 + 6
    # More runs later: only the new run indices are computed.
    more = run_sweep(_smoke_plan(runs=4), tmp_path / "full", jobs=1, progress=False)
    assert (more.computed, more.reused) == (2, 6)


def test_a_folder_holding_another_sweep_is_refused(tmp_path):
    run_sweep(_smoke_plan(runs=1), tmp_path / "s", jobs=1, progress=False)
    with pytest.raises(SweepError, match="other scenarios or grid points"):
        run_sweep(_smoke_plan(runs=1, sigmas=(100, 250)), tmp_path / "s", jobs=1, progress=False)


def test_diverged_runs_are_recorded_and_excluded(tmp_path):
    # A 1 m divergence bound trips in every run: failures are rows with a status, never averaged in.
    plan = _smoke_plan(runs=2, sigmas=(150,), extra=[("filter.divergence_position_km", [0.001, 10000])])
    result = run_sweep(plan, tmp_path / "d", jobs=1, progress=False)
    runs = result.runs_table
    tight = runs[runs["filter.divergence_position_km"] == 0.001]
    assert set(tight.status) == {"diverged"} and tight.reason.str.contains("beyond").all()
    assert tight.rms_position_m.isna().all() and (tight.fail_time_s > 0).all()
    curve = result.curve_table.set_index(["filter.divergence_position_km", "spacecraft"])
    assert (curve.loc[0.001].runs_excluded == 2).all() and curve.loc[0.001].rms_position_m_mean.isna().all()
    assert (curve.loc[10000].runs_ok == 2).all()


def _sweep_args(out):
    return ["sweep", "--scenario", SCENARIOS / "smoke.yaml", "--sigma", "100:300:100",
            "--grid", "duration_days=4", "--runs", "30", "--jobs", "1", "--quiet", "--output", out]


def test_sigkill_then_resume_equals_uninterrupted(tmp_path):
    reference = run_cli(*_sweep_args(tmp_path / "reference"))
    assert reference.returncode == 0, reference.stderr
    out = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "liaison_cli", *map(str, _sweep_args(out))], cwd=REPO,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    manifest = out / "manifest.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if manifest.exists() and manifest.read_bytes().count(b"\n") >= 16:  # header + 15 tasks
            break
        time.sleep(0.005)
    assert proc.poll() is None, "the sweep finished before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done_before = manifest.read_bytes().count(b"\n") - 1
    assert 0 < done_before < 90 and not (out / "runs.parquet").exists()
    resumed = run_cli(*_sweep_args(out))
    assert resumed.returncode == 0, resumed.stderr
    reused = int(resumed.stdout.split(" reused")[0].split("computed, ")[-1])
    assert reused >= 15 and f"{90 - reused} computed" in resumed.stdout
    for name in ("runs", "curve"):
        assert (out / f"{name}.parquet").read_bytes() == (tmp_path / "reference" / f"{name}.parquet").read_bytes()
    meta = json.loads((out / "sweep.json").read_text())
    assert meta["runs_per_point"] == 30 and meta["grid"][0] == ["noise.sigma_m", [100, 200, 300]]


BAD_GRIDS = {
    "unknown_key": (["--grid", "measurement.cadence_s=60,120"], ["measurement", "'cadence_s'", "interval_s"]),
    "missing_section": (["--grid", "radio.power=1,2"], ["radio.power", "does not exist"]),
    "bad_range": (["--sigma", "50:abc"], ["--sigma", "'abc'", "start:stop[:step]"]),
    "reversed_range": (["--sigma", "700:50"], ["--sigma", "below start"]),
    "bad_value": (["--grid", "measurement.interval_s=fast"], ["measurement.interval_s", "'fast'", "number"]),
    "no_equals": (["--grid", "measurement.interval_s"], ["--grid", "key=value"]),
    # A bad byte on the command line reaches Python as a lone surrogate, which libyaml's parser cannot encode.
    "bad_byte": (["--grid", "noise.sigma_m=1,a" + b"\xff".decode("utf-8", "surrogateescape")],
                 ["--grid", "cannot read value"]),
    "nothing": ([], ["nothing to sweep"]),
    "bad_backend": (["--sigma", "100", "--backend", "spark"], ["--backend", "'spark'", "joblib, dask"]),
}


@pytest.mark.parametrize("case", sorted(BAD_GRIDS))
def test_bad_grid_gives_one_line_and_exit_2(tmp_path, case):
    """In this process (a new interpreter costs about 1.2 s a case); one case in a real process, where a warning
    or a traceback printed outside the CLI's own handling would show."""
    args, expected = BAD_GRIDS[case]
    launch = run_cli if case == "unknown_key" else run_cli_in_process
    proc = launch("sweep", SCENARIOS / "smoke.yaml", *args, "--output", tmp_path / "o", "--quiet")
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    for text in expected:
        assert text in lines[0], (text, lines[0])


def test_curve_columns_of_keys_that_end_alike_are_told_apart():
    from liaison_cli.cli.sweep import _column_labels

    assert _column_labels(["measurement.interval_s", "filter.process_noise_accel_m_s2",
                           "spacecraft.1.process_noise_accel_m_s2"]) == [
        "interval_s", "filter.process_noise_accel_m_s2", "spacecraft.1.process_noise_accel_m_s2"]
