"""Reliability items of issue 12 done so far: non-finite runs are never ok, sweep names stay plain."""

import dataclasses

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
