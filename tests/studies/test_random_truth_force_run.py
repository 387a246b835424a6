"""A truth that feels a random Gauss-Markov acceleration the filter's CRTBP lacks
(model_error.truth_acceleration_sigma_m_s2, 1e-8 m/s^2 with a 6 h memory, drawn per run), on the smoke
scenario over 3 days with 1 m ranging: with its 1e-10 SNC alone every run diverges; with empirical
accelerations of the same sigma and time constant (the matched model) every run is healthy and the filter's
sigma tells the truth: a noise model tested against its own simulated loop."""

from liaison_cli.campaign.engine.results import summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS

SIGMA_M_S2, TAU_S = 1e-8, 21600.0


def _campaign(empirical: bool):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    overrides = {"monte_carlo.runs": 12, "duration_days": 3.0, "noise.sigma_m": 1.0,
                 "model_error.truth_acceleration_sigma_m_s2": SIGMA_M_S2,
                 "model_error.truth_acceleration_time_constant_s": TAU_S}
    if empirical:
        overrides["filter.empirical_acceleration"] = {"sigma_m_s2": SIGMA_M_S2, "time_constant_s": TAU_S}
    return summary_table(run_campaign(apply_overrides(scenario, overrides), jobs=1, progress=False))


def test_matched_empirical_accelerations_are_consistent_with_a_random_force():
    without = _campaign(False)
    assert (without.status != "ok").all()  # measured: all 12 runs diverge, the last at 1.94 d
    matched = _campaign(True)
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
