"""Accuracy guard for the fast engine: same inputs, same RMS as the plain DOP853 + numpy reference EKF."""

import pytest

from benchmarks.reference import reference_ekf
from liaison_cli.analysis.metrics import summary_rows
from liaison_cli.scenario.setup import prepare_problem
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import M_PER_LU, M_S_PER_VU
from liaison_cli.estimation.estimators import estimate
from tests.conftest import SCENARIOS


@pytest.mark.parametrize("formation,days", [("eml2_lunar", 1.25), ("eml1_eml2", 1.25)])
def test_engine_rms_matches_reference_within_one_percent(formation, days):
    scenario, _ = load_scenario(SCENARIOS / f"{formation}.yaml")
    problem = prepare_problem(apply_overrides(scenario, {"duration_days": days}))
    for run in range(2):
        inputs = draw_run_inputs(problem, run)
        out = estimate("ekf", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
        assert out.ok
        ref_err, ref_sig = reference_ekf(problem, inputs.x0_hat, inputs.y_obs)
        fast = summary_rows(problem.times_s, out.err, out.sigma, problem.spacecraft, M_PER_LU, M_S_PER_VU)[0]
        ref = summary_rows(problem.times_s, ref_err, ref_sig, problem.spacecraft, M_PER_LU, M_S_PER_VU)[0]
        for a, b in zip(fast, ref):
            for key in ("rms_position_m", "rms_velocity_m_s", "rms_position_after_day1_m"):
                assert a[key] == pytest.approx(b[key], rel=0.01), (formation, run, a["spacecraft"], key)
            # In practice the agreement is far tighter than the 1 % requirement: centimetres.
            assert abs(a["rms_position_m"] - b["rms_position_m"]) < 0.5
