"""A truth that feels a constant 2.4e-8 m/s^2 the filter's CRTBP lacks (model_error.truth_acceleration_m_s2),
on the smoke scenario over 3 days with 1 m ranging: its tight SNC filter diverges; with empirical
accelerations (filter.empirical_acceleration) every run stays healthy and consistent, and the acceleration
states find the truth's within their sigma."""

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
