"""An estimated C_R state (filter.estimated_parameters: {cr}) on the dated EML1-EML2 scenario whose filter
flies a C_R off by N(0, 5 %) per run: the state converges on the truth's correction within its sigma, the
sigma shrinks from the a priori, and the spacecraft stay consistent at a process noise where the filter
without the state is not (results/reference/cr_estimation.md has the 10-run ladder)."""

import numpy as np

from liaison_cli.campaign.engine.results import summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS


def _campaign(estimate: bool):
    scenario, _ = load_scenario(SCENARIOS / "eph_eml1_eml2_dsn.yaml")
    # The Moon and the Sun only in the filter's model (the shipped scenario has every body), so that the C_R
    # state is what makes the difference.
    overrides = {"monte_carlo.runs": 3, "filter.process_noise_accel_m_s2": 1e-9,
                 "ephemeris.filter_bodies": ["moon", "sun"],
                 "filter.estimated_parameters": {"cr": 0.05} if estimate else {}}
    return summary_table(run_campaign(apply_overrides(scenario, overrides), jobs=1, progress=False))


def test_the_cr_state_converges_and_keeps_the_filter_consistent():
    with_state = _campaign(True)
    assert (with_state.status == "ok").all()
    per_run = with_state.drop_duplicates("run")
    # The a priori is 5 %; nine days of crosslink and Goldstone data bring it to 0.24 % (10 runs,
    # results/reference/cr_estimation.md); a state the data did not reach would keep its 5 %.
    assert (per_run.cr_sigma_final < 0.01).all()
    assert (np.abs(per_run.cr_error_final) < 3 * per_run.cr_sigma_final).all()
    assert (np.abs(per_run.cr_true) > 0).all()  # the filter's C_R was really off
    # Each spacecraft's own 6-state NEES in band after the settle time (measured 91-94 % over 10 runs) against
    # 7-19 % for the same filter without the state (4 of its 10 runs diverged).
    without = _campaign(False)
    assert with_state.frac_nees_spacecraft_in_band_settled.mean() > 0.8
    assert without.frac_nees_spacecraft_in_band_settled.mean() < 0.4
