"""Empirical accelerations (filter.empirical_acceleration) against forces the filter's CRTBP lacks, on the smoke
scenario over 3 days with 1 m ranging. A constant 2.4e-8 m/s^2 (model_error.truth_acceleration_m_s2): the tight
SNC filter diverges; with empirical accelerations every run stays healthy and consistent, and the acceleration
states find the truth's within their sigma. A random Gauss-Markov force drawn per run
(model_error.truth_acceleration_sigma_m_s2, 1e-8 m/s^2 with a 6 h memory): with the SNC alone every run
diverges; with empirical accelerations of the same sigma and time constant (the matched model) every run is
healthy and the filter's sigma tells the truth: a noise model tested against its own simulated loop. One file,
so that one test process compiles the EKF with empirical states for both."""

import numpy as np

from liaison_cli.campaign.engine.results import summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS

TRUTH_ACCELERATION_M_S2 = [2e-8, -1e-8, 1e-8]


def _campaign(empirical: bool):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    overrides = {"monte_carlo.runs": 4, "duration_days": 3.0, "noise.sigma_m": 1.0,
                 "model_error.truth_acceleration_m_s2": TRUTH_ACCELERATION_M_S2}
    if empirical:
        overrides["filter.empirical_acceleration"] = {"sigma_m_s2": 3e-8, "time_constant_s": 86400.0}
    return summary_table(run_campaign(apply_overrides(scenario, overrides), jobs=1, progress=False))


def test_empirical_accelerations_absorb_an_unmodelled_force():
    without = _campaign(False)
    # Measured: every run diverged at 1.55 d (its position error beyond the bound) with the filter's 1e-10 SNC.
    assert (without.status != "ok").all()
    with_states = _campaign(True)
    assert (with_states.status == "ok").all()
    # Measured over these 4 runs: position err/sigma 0.96 (EML2) and 1.24 (Lunar); own NEES in band 90 / 100 %.
    ratios = with_states.groupby("spacecraft").position_error_to_sigma_settled.mean()
    assert ratios.between(0.67, 1.5).all()
    assert with_states.frac_nees_spacecraft_in_band_settled.mean() > 0.85
    # The acceleration error (1.3-1.9e-8 of a 2.4e-8 truth) stays within its sigma (4.3-4.8e-8): the states are
    # pessimistic about a constant force, which is what a Gauss-Markov model with a 1-day memory assumes.
    truth = np.linalg.norm(TRUTH_ACCELERATION_M_S2)
    assert (with_states.rms_accel_error_settled_m_s2 < with_states.sigma_accel_settled_m_s2).all()
    assert (with_states.rms_accel_error_settled_m_s2 < truth).all()


SIGMA_M_S2, TAU_S = 1e-8, 21600.0


def _random_force_campaign(empirical: bool):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    overrides = {"monte_carlo.runs": 12, "duration_days": 3.0, "noise.sigma_m": 1.0,
                 "model_error.truth_acceleration_sigma_m_s2": SIGMA_M_S2,
                 "model_error.truth_acceleration_time_constant_s": TAU_S}
    if empirical:
        overrides["filter.empirical_acceleration"] = {"sigma_m_s2": SIGMA_M_S2, "time_constant_s": TAU_S}
    return summary_table(run_campaign(apply_overrides(scenario, overrides), jobs=1, progress=False))


def test_matched_empirical_accelerations_are_consistent_with_a_random_force():
    without = _random_force_campaign(False)
    assert (without.status != "ok").all()  # measured: all 12 runs diverge, the last at 1.94 d
    matched = _random_force_campaign(True)
    assert (matched.status == "ok").all()
    # Measured over the 12 runs: position err/sigma 1.08 (EML2) and 1.10 (Lunar); whole-state NEES in band
    # 91 % of the settled epochs (the same scenario with no force and no such states: 72 %).
    ratios = matched.groupby("spacecraft", observed=True)[["position_error_to_sigma_settled",
                                                           "velocity_error_to_sigma_settled"]].mean()
    assert ratios.stack().between(0.8, 1.25).all(), ratios
    assert matched.frac_nees_in_band_settled.mean() > 0.85
    # The acceleration states find the drawn force to their own sigma: per run and spacecraft, the error RMS
    # 1.3-2.3e-8 m/s^2 against a sigma RMS of 1.7e-8 (ratios 0.77-1.37).
    ratio = matched.rms_accel_error_settled_m_s2 / matched.sigma_accel_settled_m_s2
    assert ratio.between(0.67, 1.5).all()
