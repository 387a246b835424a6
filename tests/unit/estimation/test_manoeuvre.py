"""004 item 3 (the manoeuvre): an impulsive Delta-v in the truth and a Delta-v block in the filter state."""

import numpy as np

from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process
from liaison_cli.campaign.studies.error_budget import error_budget
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import M_PER_LU, M_S_PER_VU
from liaison_cli.estimation.estimators import estimate
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import burn_step, prepare_problem

BURN = {"epoch_days": 1.0, "delta_v_m_s": [0.3, -0.2, 0.1], "apriori_sigma_m_s": 0.02}


def _scenario(days=3.0, burn=BURN):
    scenario, _ = load_scenario(SCENARIOS / "eml2_lunar.yaml")
    return apply_overrides(scenario, {"duration_days": days, "spacecraft.0.manoeuvre": burn,
                                      "measurement.light_time": False, "initial_error.draw": "from_covariance"})


def test_the_truth_takes_the_burn_after_its_epoch():
    scenario = _scenario()
    with_burn = prepare_problem(scenario)
    without = prepare_problem(apply_overrides(scenario, {"spacecraft.0.manoeuvre": None}))
    k = burn_step(scenario, scenario.spacecraft[0].manoeuvre)
    assert np.array_equal(with_burn.truth[: k + 1], without.truth[: k + 1])  # the epoch itself: before the burn
    # One step on, the orbits part by about Delta-v x interval (the burn, then the same flow).
    step_s = scenario.measurement.interval_s
    apart_m = np.linalg.norm(with_burn.truth[k + 1, :3] - without.truth[k + 1, :3]) * M_PER_LU
    assert abs(apart_m - np.linalg.norm(BURN["delta_v_m_s"]) * step_s) < 0.05 * apart_m
    assert with_burn.filter.layout.n == 15 and list(with_burn.filter.burns[0]) == [12, 0, k]


def test_the_filter_solves_for_the_delta_v_consistently():
    """30 runs: the Delta-v estimate error at the end is well inside its a-priori spread and consistent with
    the filter's own sigma (mean normalised square 0.5-1.6 over 90 numbers); the LinCov total of the position
    error after t0 matches the Monte Carlo within 25 %."""
    problem = prepare_problem(_scenario())
    start = problem.manoeuvres[0][0]
    errors, sigmas, mc = [], [], []
    for run in range(30):
        inputs = draw_run_inputs(problem, run)
        history = estimate("ekf", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
        assert history.ok, history.reason
        errors.append(history.err[-1, start : start + 3])
        sigmas.append(history.sigma[-1, start : start + 3])
        e = history.err[:, :12].reshape(-1, 2, 6)[:, :, :3] * M_PER_LU
        mc.append(np.sum(e**2, axis=2))
    errors, sigmas = np.array(errors), np.array(sigmas)
    assert np.sqrt(np.mean(errors**2)) * M_S_PER_VU < 0.5 * BURN["apriori_sigma_m_s"]
    assert 0.5 < np.mean((errors / sigmas) ** 2) < 1.6
    budget = error_budget(problem)
    use = problem.times_s > 0
    ratio = np.mean(mc, axis=0)[use].mean(axis=0) / budget.total[use, :, 0].mean(axis=0)
    assert np.all(np.abs(ratio - 1.0) < 0.25), ratio


def test_a_manoeuvre_outside_the_scenario_is_one_line(tmp_path):
    path = edited_scenario(tmp_path, "eml2_lunar.yaml", "    orbit: eml2_halo\n",
                           "    orbit: eml2_halo\n    manoeuvre: {epoch_days: 12, delta_v_m_s: [1, 0, 0], "
                           "apriori_sigma_m_s: 0.1}\n")
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path,
                          ["spacecraft[0].manoeuvre.epoch_days = 12", "outside the scenario"])
