"""The EKF's initial batch (issue 26 item 4, estimation.initial_batch): a MAP batch solve over the first hours,
handed over with its covariance. Against physics: with no process noise the batch's hand-over estimate and
covariance are the Kalman filter's at the same epoch (the same linear-Gaussian posterior); through a campaign
its rows and histories say what it did; bad windows are refused in one line."""

from dataclasses import replace

import numpy as np
import pytest

from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import M_PER_LU
from liaison_cli.estimation.estimators import estimate
from liaison_cli.estimation.initial_batch import InitialBatchSettings, solve_initial_batch, window_lengths
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process

NO_PROCESS_NOISE = {"filter.process_noise_accel_m_s2": 0.0, "spacecraft.1.process_noise_accel_m_s2": None,
                    "initial_error.draw": "from_covariance", "measurement.light_time": False,
                    "filter.initial_sigma_position_m": 100.0, "filter.initial_sigma_velocity_m_s": 0.001}


@pytest.mark.parametrize("noise", [{}, {"filter.empirical_acceleration": {"sigma_m_s2": 1e-8, "time_constant_s": 1e12}}],
                         ids=["spacecraft", "with-empirical-blocks"])
def test_the_hand_over_equals_the_kalman_filter_without_process_noise(noise):
    """Smoke (EML2 halo + lunar orbiter, 150 m range) with Q = 0: after 200 intervals (10.4 h) the batch's
    propagated MAP estimate and covariance equal the EKF's update at that epoch, for every state: also with
    empirical-acceleration blocks whose time constant (1e12 s) leaves them constant parameters with an a
    priori (their noise over the window is ~1e-8 of it). Measured: estimates within 8e-4 sigma, sigmas within
    2e-4 relative (the rest is the EKF's sequential relinearisation)."""
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    problem = prepare_problem(apply_overrides(scenario, {**NO_PROCESS_NOISE, **noise}))
    e = 200
    arrays = replace(problem.filter, initial_batch=InitialBatchSettings(e + 1, e + 1, 1.0, 30, 1e-6 / M_PER_LU))
    assert arrays.Q.shape[0] == (12 if not noise else 18)
    for run in range(3):
        inputs = draw_run_inputs(problem, run)
        plain = estimate("ekf", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
        solution = solve_initial_batch(arrays, inputs.x0_hat, inputs.y_obs)
        assert solution.status == "ok" and solution.traj.shape[0] == e + 1
        sigma_batch = np.sqrt(np.diag(solution.P_handover))
        assert np.abs((solution.x_handover - inputs.truth[e]) - plain.err[e]).max() <= 0.01 * plain.sigma[e].min()
        assert np.abs(sigma_batch / plain.sigma[e] - 1.0).max() <= 1e-3
        # The window's own history is the solution mapped along its reference (a smoothed estimate): its
        # last epoch is the hand-over.
        assert np.allclose(solution.sigma[-1] ** 2, np.diag(solution.covariance[-1]))


def test_windows_double_up_to_the_longest():
    settings = InitialBatchSettings(first_window=145, max_window=2305, handover_sigma_lu=1.0, max_iterations=5,
                                    tolerance_lu=1e-9)
    assert window_lengths(settings) == [145, 289, 577, 1153, 2305]
    assert window_lengths(replace(settings, max_window=145)) == [145]


def test_a_campaign_with_an_initial_batch_reports_it():
    """Smoke from a 10 km / 1 cm/s a priori with a 3-hour batch: every run's row carries the window (3 h, or
    longer when the hand-over sigma is above 1 km; whole measurement intervals), the solve's iterations and a post-fit chi-square per
    measurement near 1; the EKF's innovations start after the window."""
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    scenario = apply_overrides(scenario, {"filter.initial_sigma_position_m": 1e4,
                                          "filter.initial_sigma_velocity_m_s": 0.01,
                                          "initial_error.draw": "from_covariance",
                                          "filter.initial_batch_hours": 3.0, "filter.initial_batch_max_hours": 12.0,
                                          "filter.initial_batch_handover_sigma_km": 1.0})
    campaign = run_campaign(scenario, runs=2, jobs=1, progress=False)
    interval_h = scenario.measurement.interval_s / 3600.0
    windows_h = [(w - 1) * interval_h for w in window_lengths(campaign.problem.filter.initial_batch)]
    assert windows_h[0] == pytest.approx(3.0, abs=interval_h) and windows_h[-1] == pytest.approx(12.0, abs=interval_h)
    for outcome in campaign.outcomes:
        assert outcome.status == "ok", outcome.reason
        row = outcome.summary[0]
        assert min(abs(row["initial_batch_window_h"] - w) for w in windows_h) < 1e-9
        assert row["initial_batch_iterations"] >= 1
        assert 0.5 < row["initial_batch_chi2_per_measurement"] < 1.5
        window = int(round(row["initial_batch_window_h"] / interval_h))
        assert np.isnan(outcome.innovation_m[:window]).all() and np.isfinite(outcome.innovation_m[window + 1]).any()
        assert np.isfinite(outcome.norms["position_error_m"]).all()


@pytest.mark.parametrize("filter_text,fragments", [
    ("{initial_batch_hours: 0.05}", ["filter.initial_batch_hours = 0.05", "at least 0.104167 h"]),
    ("{initial_batch_hours: 6, initial_batch_max_hours: 30}",
     ["filter.initial_batch_max_hours = 30", "shorter than the scenario's 30 h"]),
    ("{initial_batch_hours: 6, initial_batch_max_hours: 3}", ["initial_batch_max_hours = 3", "initial_batch_hours = 6"]),
    ("{initial_batch_hours: 6, smoother: rts}", ["filter.initial_batch_hours with filter.smoother = 'rts'"]),
])
def test_a_bad_initial_batch_window_is_one_line(tmp_path, filter_text, fragments):
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:", f"filter: {filter_text}\nmonte_carlo:")
    assert_one_line_error(run_cli_in_process("validate", path), path, fragments)


def test_a_manoeuvre_inside_the_window_is_one_line(tmp_path):
    path = edited_scenario(tmp_path, "004/low_energy_transfer.yaml", "initial_batch_max_hours: 96",
                           "initial_batch_max_hours: 1200")
    assert_one_line_error(run_cli_in_process("validate", path), path,
                          ["spacecraft[0].manoeuvre.epoch_days = 47.6", "inside the initial batch window (1200 h)"])


def test_the_batch_carries_the_physical_process_noise_of_empirical_accelerations(monkeypatch):
    """Smoke with Gauss-Markov accelerations (sigma 1e-8 m/s^2, tau 1 d) and no data over 200 intervals: the
    hand-over covariance is the prediction alone, Phi P0 Phi' plus the process noise accumulated by the dense
    step, and equals the EKF's (whose coupled step takes Q in its reduced form) to 1e-9 in every sigma. The
    reduced form itself in the dense step would be wrong by far more (checked)."""
    from liaison_cli.estimation.estimators import FilterArrays

    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    dmc = {"filter.empirical_acceleration": {"sigma_m_s2": 1e-8, "time_constant_s": 86400.0}}
    problem = prepare_problem(apply_overrides(scenario, {**NO_PROCESS_NOISE, **dmc}))
    e = 200
    arrays = replace(problem.filter, initial_batch=InitialBatchSettings(e + 1, e + 1, 1.0, 30, 1e-6 / M_PER_LU))
    inputs = draw_run_inputs(problem, 0)
    no_data = np.full_like(inputs.y_obs, np.nan)
    plain = estimate("ekf", problem.filter, inputs.x0_hat, no_data, inputs.truth)
    solution = solve_initial_batch(arrays, inputs.x0_hat, no_data)
    assert solution.status == "ok" and solution.measurements == 0
    sigma = np.sqrt(np.diag(solution.P_handover))
    assert np.abs(sigma / plain.sigma[e] - 1.0).max() < 1e-9
    monkeypatch.setattr(FilterArrays, "dense_process_noise", lambda self: self.Q)  # the reduced form instead
    wrong = np.sqrt(np.diag(solve_initial_batch(arrays, inputs.x0_hat, no_data).P_handover))
    assert np.abs(wrong / plain.sigma[e] - 1.0).max() > 1e-4


@pytest.mark.slow  # compiles the dated initial batch with a parameter block (~1 min on a cold cache)
def test_the_dated_hand_over_with_an_estimated_c_r_equals_the_kalman_filter():
    """The dated EML1-EML2 pair with its C_R correction as a state (its filter's C_R off by N(0, 5 %) per run)
    and no process noise: after 250 intervals (69 h) the batch's hand-over of every state, the C_R correction
    and its coupling to the spacecraft included, is the EKF's at that epoch. Measured over 2 runs: estimates
    within 7e-4 of each state's own sigma, sigmas within 3.5e-5 relative; the C_R sigma 0.026 from its 0.05."""
    scenario, _ = load_scenario(SCENARIOS / "eph_eml1_eml2_dsn.yaml")
    problem = prepare_problem(apply_overrides(scenario, {
        "duration_days": 3.0, "filter.process_noise_accel_m_s2": 0.0, "initial_error.draw": "from_covariance",
        "filter.initial_sigma_position_m": 100.0, "filter.initial_sigma_velocity_m_s": 0.001}))
    e = 250
    assert problem.filter.Q.shape[0] == 13  # two spacecraft and the formation's C_R
    for run in range(2):
        inputs = draw_run_inputs(problem, run)
        flown = replace(problem.filter, model_params=inputs.filter_params)  # this run's C_R error
        plain = estimate("ekf", flown, inputs.x0_hat, inputs.y_obs, inputs.truth)
        arrays = replace(flown, initial_batch=InitialBatchSettings(e + 1, e + 1, 1.0, 30, 1e-6 / M_PER_LU))
        solution = solve_initial_batch(arrays, inputs.x0_hat, inputs.y_obs)
        assert solution.status == "ok"
        sigma_batch = np.sqrt(np.diag(solution.P_handover))
        gap = np.abs((solution.x_handover - inputs.truth[e]) - plain.err[e]) / plain.sigma[e]  # each in its own sigma
        assert gap.max() <= 0.01
        assert np.abs(sigma_batch / plain.sigma[e] - 1.0).max() <= 1e-3
        assert sigma_batch[12] < 0.035  # the data reached the C_R state
