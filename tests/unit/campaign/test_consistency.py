"""Consistency is an output (issue 26, item 1): per run and spacecraft, after `filter.settle_days`, the error
RMS and the filter's sigma RMS, their ratio, the share of epochs whose NEES lies in its 95 % chi-square band
(and above it), and the verdict (analysis.consistency); `liaison run` prints them per spacecraft and names
the test that failed."""

import math

import numpy as np

from liaison_cli.analysis.consistency import campaign_verdict
import pytest

from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT, nees_run_band
from liaison_cli.campaign.engine import results as results_module
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process

MATCHED = {"initial_error.draw": "from_covariance", "measurement.light_time": False,
           "spacecraft.1.process_noise_accel_m_s2": 1e-7, "filter.settle_days": 0.25}


def _campaign_ratio(group, kind, unit):
    return math.sqrt((group[f"rms_{kind}_settled_{unit}"] ** 2).mean()
                     / (group[f"sigma_{kind}_settled_{unit}"] ** 2).mean())


def test_a_matched_filter_has_error_equal_to_sigma_and_nees_in_band():
    """Initial errors drawn from P0, the truth's models in the filter: the error RMS over 30 runs equals the
    sigma RMS (measured 0.93-1.00), the whole-state NEES lies in its band at 88-100 % of the epochs (tested) and the
    campaign verdict holds (per spacecraft 89.9 % in band, which set NEES_REQUIRED_SHARE at 85 %)."""
    scenario = apply_overrides(load_scenario(SCENARIOS / "smoke.yaml")[0], MATCHED)
    table = results_module.summary_table(run_campaign(scenario, runs=30, jobs=2, progress=False))
    for _, group in table.groupby("spacecraft"):
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            assert 0.8 <= _campaign_ratio(group, kind, unit) <= 1.2
        assert 0.88 <= group.frac_nees_in_band_settled.mean() <= 1.0
        assert group.frac_nees_above_band_settled.mean() <= 0.05
        # Single runs spread (a run's NEES shares over strongly correlated epochs); the campaign is the verdict.
        verdict = campaign_verdict(group)
        assert verdict["consistent_settled"], verdict["consistency_failed"]


def test_a_filter_started_far_outside_its_covariance_is_flagged():
    """True initial errors 10x the filter's a priori: error RMS ~10x sigma RMS after the settle time, every
    run flagged, no NEES in band."""
    overrides = {**MATCHED, "initial_error.draw": "fixed_sigma", "initial_error.sigma_position_m": 10_000.0,
                 "initial_error.sigma_velocity_m_s": 0.1}
    scenario = apply_overrides(load_scenario(SCENARIOS / "smoke.yaml")[0], overrides)
    table = results_module.summary_table(run_campaign(scenario, runs=4, jobs=1, progress=False))
    for _, group in table.groupby("spacecraft"):
        assert _campaign_ratio(group, "position", "m") > 3 * CONSISTENCY_RATIO_LIMIT
        assert not group.consistent_settled.any()
        assert group.frac_nees_in_band_settled.max() < 0.05


def test_the_single_run_nees_band_is_the_chi_square_quantiles():
    low, high = nees_run_band(12)
    assert low == pytest.approx(4.40379, rel=1e-5) and high == pytest.approx(23.3367, rel=1e-5)


def test_run_prints_the_consistency_table_and_marks_an_inconsistent_spacecraft(tmp_path):
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:",
                           "initial_error: {draw: fixed_sigma, sigma_position_m: 10000, sigma_velocity_m_s: 0.1}\n"
                           "filter: {settle_days: 0.25}\nmonte_carlo:")
    proc = run_cli_in_process("run", path, "--output", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    assert "consistency after 0.25 d" in proc.stdout
    for name in ("EML2", "Lunar"):  # started 10 x outside P0: optimistic, and said so with the test that failed
        assert any(line.startswith(f"not consistent: {name}: ") and "optimistic" in line
                   for line in proc.stdout.splitlines()), proc.stdout
    lines = proc.stdout.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("spacecraft") and "consistent" in line)
    rows = lines[header + 1 : header + 3]  # the consistency table's two rows
    assert [row.split()[0] for row in rows] == ["EML2", "Lunar"] and all(row.rstrip().endswith(" no") for row in rows)
    import pandas as pd

    summary = pd.read_parquet(tmp_path / "out" / "summary.parquet")
    assert summary.consistent_settled.dtype == bool and not summary.consistent_settled.any()
    assert np.isfinite(summary.position_error_to_sigma_settled).all()


def test_a_settle_time_beyond_the_scenario_is_one_line(tmp_path):
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:", "filter: {settle_days: 2}\nmonte_carlo:")
    assert_one_line_error(run_cli_in_process("run", path, "--output", tmp_path / "out"), path,
                          ["filter.settle_days = 2", "shorter than the scenario's 1.25 d"])


def test_a_sweep_curve_carries_consistency_and_marks_an_inconsistent_point(tmp_path):
    import pandas as pd

    out = tmp_path / "sweep"
    proc = run_cli_in_process("sweep", SCENARIOS / "smoke.yaml", "--grid", "initial_error.sigma_position_m=1000,20000",
                   "--grid", "initial_error.draw=fixed_sigma",
                   "--grid", "initial_error.sigma_velocity_m_s=0.01", "--runs", "2", "--jobs", "1", "--quiet",
                   "--output", out)
    assert proc.returncode == 0, proc.stderr
    curve = pd.read_parquet(out / "curve.parquet")
    good = curve[curve["initial_error.sigma_position_m"] == 1000]  # drawn as the filter's P0
    bad = curve[curve["initial_error.sigma_position_m"] == 20000]
    assert not bad.consistent_settled.any() and (bad.consistency_failed.str.contains("optimistic")).all()
    # The point drawn as P0 passes the ratio test (its 95 % interval over 2 runs); the smoke scenario's NEES test is its own finding (whole-state
    # NEES above its band 30 % of the time over 2 runs), said in consistency_failed rather than hidden.
    assert not good.consistency_failed.str.contains("err/sigma").any()
    assert (bad.position_error_to_sigma_settled > 3 * CONSISTENCY_RATIO_LIMIT).all()
    assert "! inconsistent after the settle time" in proc.stdout
