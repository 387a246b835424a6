"""Issue 34 item 5: the `model_error` section makes the filter's dynamics differ from the truth's on purpose."""

import numpy as np
import pytest

from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.ephemeris import GM_KM3_S2
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process


def _smoke(**model_error):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    return apply_overrides(scenario, {f"model_error.{k}": v for k, v in model_error.items()})


def test_a_lunar_gm_error_changes_the_crtbp_mass_ratio_as_the_masses_do():
    problem = prepare_problem(_smoke(moon_gm_bias=1e-3))
    mu = problem.mu
    gm_moon, gm_earth = mu, 1.0 - mu  # in units of the system's GM
    expected = gm_moon * 1.001 / (gm_earth + gm_moon * 1.001)
    assert problem.filter.model_params[0] == pytest.approx(expected, rel=1e-14)
    assert problem.dynamics.params[0] == mu  # the truth keeps the true mass ratio


def test_a_drawn_error_is_seeded_by_run_and_absent_unless_asked():
    plain = prepare_problem(_smoke())
    assert draw_run_inputs(plain, 0).filter_params is None  # no draw: every other number stays as it was
    problem = prepare_problem(_smoke(moon_gm_sigma=1e-4))
    first, again, other = (draw_run_inputs(problem, run).filter_params for run in (0, 0, 1))
    assert np.array_equal(first, again) and not np.array_equal(first, other)
    relative = (first[0] / (1 - first[0])) / (problem.mu / (1 - problem.mu)) - 1.0  # the GM ratio's change
    assert 0 < abs(relative) < 5e-4
    # The draw comes after everything else: the initial errors and the noise are those of the plain scenario.
    np.testing.assert_array_equal(draw_run_inputs(problem, 1).x0_hat, draw_run_inputs(plain, 1).x0_hat)


def test_the_dated_filter_scales_only_the_moon_and_c_r():
    from liaison_cli.dynamics.ephemeris_model import HEADER, PARAM_CR_AM

    scenario, _ = load_scenario(SCENARIOS / "eph_eml1_eml2_dsn.yaml")
    scenario = apply_overrides(scenario, {"duration_days": 1, "model_error.cr_bias": 0.1,
                                          "model_error.moon_gm_bias": 0.01})
    problem = prepare_problem(scenario)
    base, biased = problem.dynamics.filter_params, problem.filter.model_params
    assert biased[PARAM_CR_AM] == pytest.approx(1.1 * base[PARAM_CR_AM], rel=1e-15)
    changed = np.flatnonzero(biased != base)
    assert len(changed) == 2 and PARAM_CR_AM in changed
    gm_index = int(changed[changed != PARAM_CR_AM][0])
    assert gm_index > HEADER and biased[gm_index] == pytest.approx(1.01 * GM_KM3_S2[301], rel=1e-12)


def test_a_c_r_error_in_the_crtbp_is_one_line(tmp_path):
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:", "model_error: {cr_bias: 0.05}\nmonte_carlo:")
    assert_one_line_error(run_cli_in_process("validate", path), path, ["model_error.cr_bias", "dynamics: ephemeris"])


def test_the_error_budget_has_a_part_for_a_drawn_lunar_gm_error():
    from liaison_cli.campaign.studies.error_budget import error_budget

    scenario = apply_overrides(_smoke(moon_gm_sigma=1e-6), {"measurement.light_time": False})
    budget = error_budget(prepare_problem(scenario))
    part = budget.parts["moon_gm"]
    assert np.all(np.isfinite(part)) and part[-1].sum() > 0.0
    without = error_budget(prepare_problem(apply_overrides(scenario, {"model_error.moon_gm_sigma": 0.0})))
    assert "moon_gm" not in without.parts


def test_an_unmodelled_truth_acceleration_is_the_budgets_dynamics_part():
    """model_error.truth_acceleration_m_s2: the truth moves, the filter's model does not; the error budget's
    deterministic dynamics part carries it (on the smoke scenario, 1e-8 m/s^2 along x raises that part's
    RMS over the last epochs of the EML2 halo from millimetres to tens of metres; measured 0.004 m and 41 m)."""
    from liaison_cli.campaign.studies.error_budget import error_budget

    base = apply_overrides(_smoke(), {"measurement.light_time": False})
    pushed = apply_overrides(base, {"model_error.truth_acceleration_m_s2": [1e-8, 0.0, 0.0]})
    plain_problem, pushed_problem = prepare_problem(base), prepare_problem(pushed)
    assert not np.array_equal(plain_problem.truth, pushed_problem.truth)
    assert np.array_equal(plain_problem.filter.model_params, pushed_problem.filter.model_params)
    parts = [error_budget(p).parts["dynamics_model"] for p in (plain_problem, pushed_problem)]
    rms = [float(np.sqrt(np.mean(part[-10:, 0]))) for part in parts]
    assert rms[1] > 100 * max(rms[0], 1e-3)


@pytest.mark.parametrize("edit, fragments", [
    ("model_error: {truth_acceleration_m_s2: [1.0e-4, 0, 0]}", ["truth_acceleration_m_s2", "at most 1e-5"]),
])
def test_an_unmodelled_acceleration_out_of_range_is_one_line(tmp_path, edit, fragments):
    path = edited_scenario(tmp_path, "smoke.yaml", "monte_carlo:", f"{edit}\nmonte_carlo:")
    assert_one_line_error(run_cli_in_process("validate", path), path, fragments)


@pytest.mark.parametrize("key, value", [("truth_acceleration_m_s2", "[1.0e-9, 0, 0]"),
                                        ("truth_acceleration_sigma_m_s2", "1.0e-9, truth_acceleration_time_constant_s: 3600")])
def test_an_unmodelled_acceleration_on_a_corrected_dated_orbit_is_one_line(tmp_path, key, value):
    path = edited_scenario(tmp_path, "eph_eml1_eml2_dsn.yaml", "monte_carlo:",
                           f"model_error: {{{key}: {value}}}\nmonte_carlo:")
    assert_one_line_error(run_cli_in_process("validate", path), path,
                          [f"model_error.{key} = ", "spacecraft[0]", "corrected"])
