"""Issue 34 item 5: a random unmodelled acceleration in the truth (model_error.truth_acceleration_sigma_m_s2),
a first-order Gauss-Markov path per estimated spacecraft drawn per run, so that each run flies and measures
its own truth."""

import numpy as np
import pytest

from liaison_cli.campaign.engine.worker import draw_run_inputs, run_truth
from liaison_cli.dynamics.constants import M_S2_PER_AU, MU, TU_S
from liaison_cli.dynamics.crtbp import derivative
from liaison_cli.dynamics.integrators.adaptive import dop853_samples
from liaison_cli.dynamics.integrators.rk4 import rk4_states, rk4_states_forced
from liaison_cli.dynamics.random_forcing import gauss_markov_samples
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.reference_states import initial_state_lu
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process

SIGMA_M_S2, TAU_S = 1e-8, 21600.0


def _smoke(**model_error):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    return apply_overrides(scenario, {f"model_error.{k}": v for k, v in model_error.items()})


def test_gauss_markov_samples_have_the_stationary_spread_and_the_memory():
    sigma, tau_s, step_s = 2.0, 400.0, 100.0
    samples = gauss_markov_samples(np.random.default_rng(1), 2000, 120, step_s, sigma, tau_s)
    assert samples.shape == (2000, 120, 3)
    # Every epoch has variance sigma^2 (6,000 values each: the estimate's own spread is 1.8 %).
    for k in (0, 1, 60, 119):
        assert np.var(samples[:, k]) == pytest.approx(sigma**2, rel=0.06)
    # Lag-1 and lag-4 correlations phi and phi^4, pooled over epochs and axes (spread ~0.002).
    phi = np.exp(-step_s / tau_s)
    for lag in (1, 4):
        correlation = np.mean(samples[:, lag:] * samples[:, :-lag]) / sigma**2
        assert correlation == pytest.approx(phi**lag, abs=0.02)
    # One process's path does not depend on how many others are drawn.
    fewer = gauss_markov_samples(np.random.default_rng(1), 1, 120, step_s, sigma, tau_s)
    np.testing.assert_array_equal(fewer[0], samples[0])


def test_a_forced_truth_follows_dop853_under_the_same_force():
    """The compiled truth's RK4 (10 s steps) against scipy's DOP853 with the same force, linear between the
    epochs (np.interp): an independent integration of the same equations."""
    spec = load_scenario(SCENARIOS / "smoke.yaml")[0].spacecraft[1]  # the lunar orbiter: the fastest dynamics
    state0 = initial_state_lu(spec)
    times_tu = np.arange(97) * 187.5 / TU_S  # 5 h
    force = gauss_markov_samples(np.random.default_rng(3), 1, 97, 187.5, 1e-6 / M_S2_PER_AU, 3600.0)[0]
    forced = rk4_states_forced(state0, times_tu, 10.0 / TU_S, MU, force)

    def rhs(t, y):
        rate = derivative(y, MU)
        rate[3:] += [np.interp(t, times_tu, force[:, i]) for i in range(3)]
        return rate

    reference = dop853_samples(rhs, 0.0, state0, times_tu, 1e-13, 1e-15)
    moved_m = np.max(np.linalg.norm(forced[:, :3] - rk4_states(state0, times_tu, 10.0 / TU_S, MU)[:, :3], axis=1))
    off_m = np.max(np.linalg.norm(forced[:, :3] - reference[:, :3], axis=1))
    lu_m = 384400e3
    assert moved_m * lu_m > 10.0  # the force moved the orbiter by metres (measured 46 m)
    assert off_m * lu_m < 1e-3  # and both integrations agree to a millimetre (measured 0.26 mm; held piecewise constant instead: 3.3 m)
    # A constant table adds its row exactly: the same as a constant force.
    constant = np.tile(force[0], (97, 1))
    again = rk4_states_forced(state0, times_tu, 10.0 / TU_S, MU, constant)
    np.testing.assert_array_equal(again, rk4_states_forced(state0, times_tu, 10.0 / TU_S, MU, constant.copy()))


def test_each_run_flies_its_own_truth_and_no_other_draw_moves():
    plain = prepare_problem(_smoke())
    problem = prepare_problem(_smoke(truth_acceleration_sigma_m_s2=SIGMA_M_S2,
                                     truth_acceleration_time_constant_s=TAU_S))
    assert plain.trajectories is None and problem.trajectories is not None
    first, again, other = (draw_run_inputs(problem, run) for run in (0, 0, 1))
    np.testing.assert_array_equal(first.truth, again.truth)
    np.testing.assert_array_equal(first.y_obs, again.y_obs)
    assert not np.array_equal(first.truth, other.truth)
    # Every run starts from the nominal state; the force moves the truth by metres over the 1.25 days.
    np.testing.assert_array_equal(first.truth[0], plain.truth[0])
    moved_m = np.max(np.abs(first.truth[:, :3] - plain.truth[:, :3])) * 384400e3
    assert 1.0 < moved_m < 1e4
    # The force has its own stream: initial errors and noise are the plain scenario's.
    base = draw_run_inputs(plain, 0)
    np.testing.assert_array_equal(first.x0_hat, base.x0_hat)
    own_truth, own_measurements, forcing = run_truth(problem, 0)
    np.testing.assert_allclose(first.y_obs[1:] - own_measurements[1:], base.y_obs[1:] - plain.measurements_true[1:],
                               rtol=0, atol=1e-12)
    # The run's measurements follow its own truth: the range moves by the line-of-sight share of the moves.
    moved = own_truth - plain.truth
    line = plain.truth[:, 6:9] - plain.truth[:, 0:3]
    line /= np.linalg.norm(line, axis=1, keepdims=True)
    expected = np.sum(line * (moved[:, 6:9] - moved[:, 0:3]), axis=1)
    change = own_measurements[1:, 0] - plain.measurements_true[1:, 0]
    assert np.max(np.abs(change)) * 384400e3 > 1.0
    np.testing.assert_allclose(change, expected[1:], rtol=0, atol=1e-3 * np.max(np.abs(expected)))
    # The drawn acceleration has the stated spread (2 x 3 x 577 correlated samples: loose) and is per spacecraft.
    drawn_m_s2 = np.stack(list(forcing.values())) * M_S2_PER_AU
    assert set(forcing) == {"EML2", "Lunar"} and 0.3 * SIGMA_M_S2 < np.std(drawn_m_s2) < 2.0 * SIGMA_M_S2


def test_the_empirical_states_truth_is_the_drawn_acceleration():
    problem = prepare_problem(_smoke(truth_acceleration_sigma_m_s2=SIGMA_M_S2, truth_acceleration_time_constant_s=TAU_S,
                                     truth_acceleration_m_s2=[1e-9, 0.0, 0.0]))
    problem = prepare_problem(apply_overrides(problem.scenario, {
        "filter.empirical_acceleration": {"sigma_m_s2": SIGMA_M_S2, "time_constant_s": TAU_S}}))
    inputs = draw_run_inputs(problem, 2)
    _, _, forcing = run_truth(problem, 2)
    layout = problem.filter.layout
    start = layout.starts[[b.owner for b in layout.blocks].index("accel Lunar")]
    expected = forcing["Lunar"] + np.array([1e-9, 0.0, 0.0]) / M_S2_PER_AU
    np.testing.assert_array_equal(inputs.truth[:, start : start + 3], expected)


@pytest.mark.parametrize("edit, fragments", [
    ("model_error: {truth_acceleration_sigma_m_s2: 1.0e-8}",
     ["model_error.truth_acceleration_time_constant_s = None", "measurement.interval_s = 187.5"]),
    ("model_error: {truth_acceleration_sigma_m_s2: 1.0e-8, truth_acceleration_time_constant_s: 60}",
     ["truth_acceleration_time_constant_s = 60", "from measurement.interval_s = 187.5 s up"]),
    ("model_error: {truth_acceleration_time_constant_s: 3600}",
     ["truth_acceleration_time_constant_s = 3600 without truth_acceleration_sigma_m_s2", "both, or neither"]),
    ("measurements: {tdm: none.tdm}\nmodel_error: {truth_acceleration_sigma_m_s2: 1.0e-8, "
     "truth_acceleration_time_constant_s: 3600}",
     ["truth_acceleration_sigma_m_s2 with measurements: {tdm: ...}", "allowed: simulated measurements"]),
])
def test_a_random_force_without_its_settings_is_one_line(tmp_path, edit, fragments):
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:", f"{edit}\nmonte_carlo:")
    assert_one_line_error(run_cli_in_process("validate", path), path, fragments)
