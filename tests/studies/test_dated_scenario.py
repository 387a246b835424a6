"""003 item 6 (first part): a `dynamics: ephemeris` scenario runs through the same engine, and its Monte Carlo
errors agree with the error budget; dated bad input is one line."""

import numpy as np
import pytest

from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process
from liaison_cli.campaign.studies.error_budget import error_budget
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import M_PER_LU
from liaison_cli.estimation.estimators import estimate
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem

DATED = SCENARIOS / "eph_eml1_eml2_dsn.yaml"


def test_dated_scenario_runs_and_matches_its_error_budget():
    """Two days, 20 runs: every run ok, the 2-sigma share sane, and the mean-square position error after t0
    within 30 % of the LinCov total of the same scenario (20 runs: the sampling error alone is ~15 %)."""
    scenario, _ = load_scenario(DATED)
    scenario = apply_overrides(scenario, {"duration_days": 2, "monte_carlo.runs": 20})
    problem = prepare_problem(scenario)
    budget = error_budget(problem)
    use = problem.times_s > 0
    mc = []
    for run in range(20):
        inputs = draw_run_inputs(problem, run)
        history = estimate("ekf", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
        assert history.ok, history.reason
        e = history.err[:, :12].reshape(-1, 2, 6)[:, :, :3] * M_PER_LU
        mc.append(np.sum(e**2, axis=2))
    mc = np.mean(mc, axis=0)
    ratio = mc[use].mean(axis=0) / budget.total[use, :, 0].mean(axis=0)
    assert np.all(np.abs(ratio - 1.0) < 0.3), ratio
    assert budget.parts["dynamics_model"][use].mean() < 1e-3 * budget.total[use].mean()  # RK8 = truth, to 0.1 %


@pytest.mark.parametrize("old,new,fragments", [
    ('  epoch_utc: "2011-11-26T15:52:12.383"', '  epoch_utc: "2060-01-01T00:00:00"', ["outside DE421"]),
    ('  epoch_utc: "2011-11-26T15:52:12.383"', '  epoch_utc: "next tuesday"', ["ephemeris.epoch_utc", "ISO 8601"]),
    ("dynamics: ephemeris\nephemeris:\n", "dynamics: ephemeris\nunused:\n", ["unknown key 'unused'"]),
    ("  light_time: false", "  light_time: true", ["measurement.light_time: false"]),
])
def test_bad_dated_input_is_one_line(tmp_path, old, new, fragments):
    path = edited_scenario(tmp_path, "eph_eml1_eml2_dsn.yaml", old, new)
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, fragments)


def test_dynamics_ephemeris_without_an_epoch_is_one_line(tmp_path):
    text = DATED.read_text()
    start = text.index("ephemeris:\n  epoch_utc")
    end = text.index("spacecraft:")
    path = tmp_path / "bad.yaml"
    path.write_text(text[:start] + text[end:])
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, ["'dynamics' = 'ephemeris' needs an 'ephemeris'"])


def test_a_link_can_carry_its_own_noise():
    """The Goldstone link's channels take its own 10 m / 0.5 mm/s, the crosslink the noise section's."""
    problem = prepare_problem(apply_overrides(load_scenario(DATED)[0], {"duration_days": 0.1}))
    sigmas = dict(zip(((ch.link_label, ch.label) for ch in problem.channels), problem.sigma_lu * problem.channel_scale_si))
    assert sigmas[("Goldstone->EML1", "range")] == pytest.approx(10.0)
    assert sigmas[("Goldstone->EML1", "range_rate")] == pytest.approx(5e-4)
    assert sigmas[("EML1->EML2", "range")] == pytest.approx(1.0)
    assert sigmas[("EML1->EML2", "range_rate")] == pytest.approx(1e-3)


def test_filter_c_r_is_drawn_per_run_and_reproducibly():
    """003: the filter's C_R is off by N(0, 5 %) per run: drawn last (no other draw moves), the same for the
    same run index, different between runs, and absent when cr_error_sigma is 0."""
    from liaison_cli.dynamics.ephemeris_model import PARAM_CR_AM

    scenario = apply_overrides(load_scenario(DATED)[0], {"duration_days": 0.2})
    problem = prepare_problem(scenario)
    base = problem.filter.model_params[PARAM_CR_AM]
    factors = [draw_run_inputs(problem, run).filter_params[PARAM_CR_AM] / base for run in range(200)]
    assert draw_run_inputs(problem, 3).filter_params[PARAM_CR_AM] == pytest.approx(factors[3] * base, rel=0)
    assert np.std(factors) == pytest.approx(0.05, rel=0.15) and abs(np.mean(factors) - 1.0) < 0.015
    plain = prepare_problem(apply_overrides(scenario, {"ephemeris.cr_error_sigma": 0.0}))
    a, b = draw_run_inputs(plain, 3), draw_run_inputs(problem, 3)
    assert a.filter_params is None
    assert np.array_equal(a.y_obs, b.y_obs, equal_nan=True) and np.array_equal(a.x0_hat, b.x0_hat)
