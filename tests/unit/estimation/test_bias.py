"""Range bias (001 §5.2, §6.3): estimated, ignored, or considered (Schmidt-Kalman)."""

import numpy as np
import pytest

from liaison_cli.campaign.engine.results import bias_table, consistency_table, summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.estimation.ekf import update_scalar
from tests.conftest import SCENARIOS, run_cli_in_process


@pytest.fixture(scope="module")
def base():
    # Matched dynamics and measurement models, so the bias is the only model error under test.
    scenario, _ = load_scenario(SCENARIOS / "eml2_lunar.yaml")
    return apply_overrides(scenario, {"duration_days": 4, "measurement.light_time": False,
                                      "spacecraft.1.process_noise_accel_m_s2": 1e-7})


def _run(base, overrides, runs):
    result = run_campaign(apply_overrides(base, overrides), runs=runs, jobs=2, progress=False)
    return result, summary_table(result)


def test_estimated_bias_lies_within_its_posterior_3_sigma(base):
    result, summary = _run(base, {"noise.bias_sigma_m": 150, "filter.bias": "estimate",
                                  "filter.bias_apriori_sigma_m": 150}, runs=20)
    table = bias_table(result)
    assert len(table) == 20 and (table.status == "ok").all()
    assert table.bias_true_m.std() > 50  # a fresh bias per run
    inside = (table.bias_estimate_m - table.bias_true_m).abs() <= 3 * table.bias_sigma_m
    assert inside.mean() >= 0.95
    assert (table.bias_sigma_m < 150).all()  # the data did inform the bias


def test_ignoring_a_3_sigma_bias_degrades_and_consider_covariance_bounds_the_error(base):
    clean = _run(base, {}, runs=10)[1].groupby("spacecraft").rms_position_m.mean()
    ignore_result, ignore = _run(base, {"noise.bias_m": 450}, runs=10)
    consider_result, consider = _run(base, {"noise.bias_m": 450, "filter.bias": "consider",
                                            "filter.bias_apriori_sigma_m": 150}, runs=10)
    degraded = ignore.groupby("spacecraft").rms_position_m.mean()
    assert degraded["EML2"] > 1.3 * clean["EML2"]  # measured: 1248 m against 834 m
    # The plain EKF covariance is far too small for the biased data; the consider covariance is not.
    nees_ignore = consistency_table(ignore_result).query("t_s > 0").mean_nees.mean()
    nees_consider = consistency_table(consider_result).query("t_s > 0").mean_nees.mean()
    assert nees_ignore > 100 and nees_consider < 3 * 12, (nees_ignore, nees_consider)
    assert (consider.groupby("spacecraft").frac_in_2sigma.mean() > ignore.groupby("spacecraft").frac_in_2sigma.mean()).all()
    table = bias_table(consider_result)
    assert np.allclose(table.bias_estimate_m, 0.0) and np.allclose(table.bias_sigma_m, 150.0)


def test_consider_gain_is_zero_and_joseph_form_still_holds():
    rng = np.random.default_rng(9)
    A = rng.standard_normal((7, 7))
    P = A @ A.T + np.eye(7)
    H = rng.standard_normal(7)
    R = 0.3
    dx, P_new, _, S = update_scalar(np.zeros(7), P, 1.0, H, R, 6)
    K = P @ H / (H @ P @ H + R)
    K[6:] = 0.0
    joseph = (np.eye(7) - np.outer(K, H)) @ P @ (np.eye(7) - np.outer(K, H)).T + R * np.outer(K, K)
    assert dx[6] == 0.0 and np.allclose(P_new, joseph)
    assert P_new[6, 6] == pytest.approx(P[6, 6])


def test_bias_treatment_needs_an_apriori_sigma(tmp_path):
    path = tmp_path / "bias.yaml"
    path.write_text((SCENARIOS / "smoke.yaml").read_text() + "filter:\n  bias: estimate\n")
    proc = run_cli_in_process("run", path, "--output", tmp_path / "o")
    assert proc.returncode == 2 and "bias_apriori_sigma_m" in proc.stderr and "Traceback" not in proc.stderr
