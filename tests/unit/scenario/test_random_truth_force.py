"""Issue 34 item 5: a random unmodelled acceleration in the truth (model_error.truth_acceleration_sigma_m_s2),
a first-order Gauss-Markov path per estimated spacecraft drawn per run, so that each run flies and measures
its own truth."""

import numpy as np
import pytest

from liaison_cli.campaign.engine.worker import draw_run_inputs, run_truth
from liaison_cli.dynamics.constants import M_S2_PER_AU, M_S_PER_VU, MU, TU_S
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
    forced = rk4_states_forced(state0, times_tu, 10.0 / TU_S, np.array([MU]), force)

    def rhs(t, y):
        rate = derivative(y, MU)
        rate[3:] += [np.interp(t, times_tu, force[:, i]) for i in range(3)]
        return rate

    reference = dop853_samples(rhs, 0.0, state0, times_tu, 1e-13, 1e-15)
    moved_m = np.max(np.linalg.norm(forced[:, :3] - rk4_states(state0, times_tu, 10.0 / TU_S, np.array([MU]))[:, :3], axis=1))
    off_m = np.max(np.linalg.norm(forced[:, :3] - reference[:, :3], axis=1))
    lu_m = 384400e3
    assert moved_m * lu_m > 10.0  # the force moved the orbiter by metres (measured 46 m)
    # Both integrations agree to a millimetre (measured 0.26 mm; the force held constant over each interval
    # instead of linear: 3.3 m off).
    assert off_m * lu_m < 1e-3


def test_each_run_flies_its_own_truth_and_no_other_draw_moves():
    plain = prepare_problem(_smoke())
    problem = prepare_problem(_smoke(truth_acceleration_sigma_m_s2=SIGMA_M_S2,
                                     truth_acceleration_time_constant_s=TAU_S))
    assert plain.unforced is None and problem.unforced == {}  # smoke: no known participant, no station
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


def _moved_range(plain, own_truth, own_measurements, station_lu):
    """(the range change the run's measurements show, the one its truth implies: the spacecraft's move along
    the station's line of sight), ranges from the station to the spacecraft, epochs 1 ... m-1."""
    moved = own_truth[:, 0:3] - plain.truth[:, 0:3]
    line = plain.truth[:, 0:3] - station_lu
    line /= np.linalg.norm(line, axis=1, keepdims=True)
    return own_measurements[1:, 0] - plain.measurements_true[1:, 0], np.sum(line * moved, axis=1)[1:]


def test_a_ground_station_measures_the_runs_own_truth_with_light_time():
    """ground_eml2: one station (visibility by elevation, light-time range): the station keeps its nominal
    track, the spacecraft flies its own, and the range moves by the spacecraft's move along the line of sight."""
    scenario, _ = load_scenario(SCENARIOS / "ground_eml2.yaml")
    force = {"model_error.truth_acceleration_sigma_m_s2": SIGMA_M_S2,
             "model_error.truth_acceleration_time_constant_s": TAU_S, "duration_days": 2.0}
    plain = prepare_problem(apply_overrides(scenario, {"duration_days": 2.0}))
    problem = prepare_problem(apply_overrides(scenario, force))
    assert set(problem.unforced) == {"Goldstone"}
    own_truth, own_measurements, _ = run_truth(problem, 0)
    station = problem.unforced["Goldstone"].states[:, 0:3]
    change, expected = _moved_range(plain, own_truth, own_measurements, station)
    seen = np.isfinite(change)
    assert seen.sum() > 100 and np.array_equal(seen, np.isfinite(plain.measurements_true[1:, 0]))
    assert np.max(np.abs(change[seen])) * 384400e3 > 1.0  # metres over two days (measured 79 m, 368 epochs)
    # Measured: within 1.3e-5 of the largest change (light time and the station's own motion).
    np.testing.assert_allclose(change[seen], expected[seen], rtol=0, atol=1e-3 * np.max(np.abs(expected[seen])))


def test_a_manoeuvre_keeps_its_delta_v_in_the_runs_own_truth():
    """The smoke scenario's EML2 burns 5 cm/s at day 0.5: its own truth under the force still jumps by exactly
    the burn at that epoch (the same split as the nominal truth), and both truths start together."""
    burn = {"spacecraft.0.manoeuvre": {"epoch_days": 0.5, "delta_v_m_s": [0.05, 0.0, 0.0], "apriori_sigma_m_s": 0.01}}
    plain = prepare_problem(apply_overrides(_smoke(), burn))
    problem = prepare_problem(apply_overrides(_smoke(truth_acceleration_sigma_m_s2=SIGMA_M_S2,
                                                     truth_acceleration_time_constant_s=TAU_S), burn))
    own_truth, _, _ = run_truth(problem, 1)
    k = int(round(0.5 * 86400.0 / 187.5))
    moved = own_truth[:, 0:6] - plain.truth[:, 0:6]
    assert np.array_equal(moved[0], np.zeros(6))
    # Across the burn epoch the force's share of the velocity change is ~1e-8 m/s^2 x 187.5 s, the burn 5 cm/s:
    # the difference of the two truths changes by no more than the force could add in one interval.
    step_change_m_s = np.abs(moved[k + 1, 3:6] - moved[k, 3:6]) * M_S_PER_VU
    assert np.max(step_change_m_s) < 20 * SIGMA_M_S2 * 187.5  # measured 1.6e-6 m/s; the burn's step is 5 cm/s
    assert np.max(np.abs(moved[-1, 0:3])) * 384400e3 > 1.0  # and the force did move it (measured 19 m)


@pytest.mark.parametrize("edit, fragments", [
    ("model_error: {truth_acceleration_sigma_m_s2: 1.0e-8}",
     ["model_error.truth_acceleration_time_constant_s is missing", "truth_acceleration_sigma_m_s2 = 1e-08",
      "measurement.interval_s = 187.5"]),
    ("model_error: {truth_acceleration_sigma_m_s2: 1.0e-8, truth_acceleration_time_constant_s: 60}",
     ["truth_acceleration_time_constant_s = 60", "from measurement.interval_s = 187.5 s up"]),
    ("model_error: {truth_acceleration_time_constant_s: 3600}",
     ["truth_acceleration_time_constant_s = 3600 without truth_acceleration_sigma_m_s2", "allowed: both (a sigma of 0: no force), or neither"]),
    ("measurements: {tdm: none.tdm}\nmodel_error: {truth_acceleration_sigma_m_s2: 1.0e-8, "
     "truth_acceleration_time_constant_s: 3600}",
     ["truth_acceleration_sigma_m_s2 = 1e-08 with measurements: {tdm: ...}", "allowed: simulated measurements"]),
])
def test_a_random_force_without_its_settings_is_one_line(tmp_path, edit, fragments):
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:", f"{edit}\nmonte_carlo:")
    assert_one_line_error(run_cli_in_process("validate", path), path, fragments)


def test_a_sigma_of_zero_with_its_time_constant_is_no_force():
    """A sweep over the sigma can start at 0 (no force) with the time constant set: an explicit 0 is no force,
    while a time constant with no sigma given at all stays refused (above)."""
    problem = prepare_problem(_smoke(truth_acceleration_sigma_m_s2=0.0, truth_acceleration_time_constant_s=TAU_S))
    plain = prepare_problem(_smoke())
    assert problem.unforced is None
    np.testing.assert_array_equal(draw_run_inputs(problem, 0).y_obs, draw_run_inputs(plain, 0).y_obs)


def test_the_error_budget_refuses_a_truth_each_run_flies_itself(tmp_path):
    """LinCov linearises about one shared truth; a drawn force gives each run its own: `liaison errors` says so
    in one line instead of a budget of the wrong truth (its check once compared each run's truth with the
    nominal measurements: ratios of 1e6 and more, reported beside an err/sigma of 1.00)."""
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:", "model_error: {truth_acceleration_sigma_m_s2: "
                           "1.0e-8, truth_acceleration_time_constant_s: 21600}\nmonte_carlo:")
    proc = run_cli_in_process("errors", path, "--output", tmp_path / "budget")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert "\n" not in line and "model_error.truth_acceleration_sigma_m_s2 = 1e-08" in line and "allowed: 0" in line


@pytest.mark.slow  # corrects 003's EML1 halo on a cold cache (~10 s)
def test_a_dated_runs_own_truth_takes_the_force_in_the_right_units():
    """003's MSL departure (its EML1 partner known, the links to it dropped): the run's truth flown under a
    drawn force that happens to be constant equals the dated model's truth under a constant force of the same
    size in km/s^2 (the model's units, axes and epoch table), and the force moves MSL by hundreds of metres."""
    import copy

    import yaml

    from liaison_cli.scenario.loading import validate_scenario
    from liaison_cli.scenario.truth import forced_truth_and_measurements

    data = yaml.safe_load((SCENARIOS / "003" / "msl.yaml").read_text())
    data["spacecraft"][0]["role"] = "known"
    data["links"] = [link for link in data["links"] if link["transponder"] != "EML1"]
    data["model_error"] = {"truth_acceleration_sigma_m_s2": 1e-9, "truth_acceleration_time_constant_s": 3600.0}
    problem = prepare_problem(validate_scenario(data, "msl"))
    push_m_s2 = np.array([2e-9, -1e-9, 3e-9])
    table = np.tile(push_m_s2 / M_S2_PER_AU, (problem.n_steps, 1))
    flown, measurements = forced_truth_and_measurements(problem.scenario, problem.dynamics, problem.times_s,
                                                        problem.unforced, {"MSL": problem.truth[0]}, {"MSL": table})
    pushed = copy.copy(problem.dynamics)
    pushed.truth_acceleration_km_s2 = push_m_s2 * 1e-3
    reference = pushed.truth_states(problem.truth[0], problem.times_s / TU_S)
    gap_m = np.max(np.linalg.norm(flown["MSL"].states[:, 0:3] - reference[:, 0:3], axis=1)) * 384400e3
    moved_m = np.max(np.linalg.norm(reference[:, 0:3] - problem.truth[:, 0:3], axis=1)) * 384400e3
    # Measured: 0 m apart; moved 1,123 m in 9 days (a t^2 / 2 = 1,131 m for |a| = 3.7e-9 m/s^2).
    assert moved_m > 100.0 and gap_m < 1e-3
    assert np.isfinite(measurements[1:]).any() and set(problem.unforced) >= {"EML1", "Goldstone"}
