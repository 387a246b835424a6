"""Process noise per radial / in-track / cross-track axis (process_noise_psd_ric_m2_s3): the step's Q against
the frame analysis.ric computes independently, the same density on all three axes against the inertial PSD
(the same matrix, so the same run), and the one-line refusals."""

import numpy as np
import pytest
from numba import njit

from liaison_cli.analysis.ric import ric_axes
from liaison_cli.campaign.engine.results import summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.errors import ScenarioError
from liaison_cli.estimation.ric_noise import step_process_noise
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS

OWN_KEYS_OFF = {"spacecraft.0.process_noise_accel_m_s2": None, "spacecraft.1.process_noise_accel_m_s2": None}


@njit(cache=True)
def _step_noise(noise, x_hat, k, block_kind, block_start):
    n = x_hat.shape[0]
    return step_process_noise(noise, np.empty((n, n)), x_hat, k, block_kind, block_start, np.empty((3, 3))).copy()


def _problem(densities):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    return prepare_problem(apply_overrides(scenario, {**OWN_KEYS_OFF, "filter.process_noise_psd_ric_m2_s3": densities}))


def test_the_step_noise_lies_along_the_frame_of_the_estimate():
    """Radial-only density: each spacecraft's position block is q dt^3/3 R R' with R the radial axis of
    analysis.ric (about the nearer primary: the Moon for the lunar orbiter), its velocity block q dt R R'."""
    q = 2e-12
    problem = _problem([q, 0.0, 0.0])
    arrays = problem.filter
    kind, start = arrays.layout.arrays()[:2]
    k = 100
    x_hat = problem.truth[k] + 1e-7  # any estimate: the frame is taken at it
    Q = _step_noise(arrays.process_noise(len(problem.times_s)), x_hat, k, kind, start)
    dt = problem.scenario.measurement.interval_s
    primaries = arrays.primaries[k : k + 1]
    for s in (0, 6):
        axes = ric_axes(x_hat[None, s : s + 3], x_hat[None, s + 3 : s + 6], primaries[:, :, :3], primaries[:, :, 3:])[0]
        radial = np.outer(axes[0], axes[0])
        expected_position = q * dt**3 / 3.0 / 384400e3**2 * radial
        assert np.allclose(Q[s : s + 3, s : s + 3], expected_position, rtol=1e-12, atol=1e-12 * np.abs(expected_position).max())
        velocity = Q[s + 3 : s + 6, s + 3 : s + 6]
        assert np.allclose(velocity / np.trace(velocity), radial, atol=1e-12)


def test_one_density_on_every_axis_is_the_inertial_psd():
    """sum over an orthonormal frame of u u' is the identity: the run equals the inertial PSD's (measured:
    bit-identical on smoke's 2 runs; allowed 1e-12 relative)."""
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    common = {**OWN_KEYS_OFF, "monte_carlo.runs": 2}
    inertial = apply_overrides(scenario, {**common, "filter.process_noise_psd_m2_s3": 1e-12})
    ric = apply_overrides(scenario, {**common, "filter.process_noise_psd_ric_m2_s3": [1e-12, 1e-12, 1e-12]})
    assert prepare_problem(ric).filter.ric_noise is not None
    columns = ["rms_position_m", "rms_velocity_m_s", "mean_nees_settled", "sigma_position_settled_m"]
    a = summary_table(run_campaign(inertial, jobs=1, progress=False))[columns].to_numpy()
    b = summary_table(run_campaign(ric, jobs=1, progress=False))[columns].to_numpy()
    assert np.allclose(a, b, rtol=1e-12, atol=0)
    # ... and a density on one axis only is another filter.
    radial = apply_overrides(scenario, {**common, "filter.process_noise_psd_ric_m2_s3": [3e-12, 0.0, 0.0]})
    c = summary_table(run_campaign(radial, jobs=1, progress=False))[columns].to_numpy()
    assert not np.allclose(a, c, rtol=1e-6)


@pytest.mark.parametrize("edits, fragment", [
    ({"filter": {"process_noise_psd_ric_m2_s3": [1e-12, 1e-12, 1e-12], "initial_batch_hours": 6.0}},
     "process_noise_psd_ric_m2_s3 with filter.initial_batch_hours"),
    ({"filter": {"process_noise_psd_ric_m2_s3": [1e-12, 1e-12, 1e-12], "process_noise_psd_m2_s3": 1e-12}},
     "not both of any two"),
    ({"filter": {"process_noise_psd_ric_m2_s3": [1e-12, -1.0, 0.0]}}, "greater than or equal to 0"),
], ids=["initial-batch", "two-conventions", "negative"])
def test_rules_are_one_line(edits, fragment):
    from liaison_cli.errors import ScenarioError
    from liaison_cli.scenario.loading import read_scenario_text, validate_scenario

    data = read_scenario_text(SCENARIOS / "smoke.yaml")[0]
    for sc in data["spacecraft"]:
        sc.pop("process_noise_accel_m_s2", None)
    data.setdefault("filter", {}).update(edits["filter"])
    with pytest.raises(ScenarioError) as refused:
        validate_scenario(data, "s.yaml")
    assert fragment in str(refused.value) and "\n" not in str(refused.value)


def test_the_error_budget_refuses_it_in_one_line():
    from liaison_cli.campaign.studies.error_budget import BudgetError, error_budget

    with pytest.raises(BudgetError, match="LinCov takes a fixed process noise"):
        error_budget(_problem([1e-12, 1e-12, 1e-12]))


def test_a_filter_level_ric_density_no_spacecraft_takes_is_refused():
    """Every spacecraft keeps its own sigma_a, so a filter RIC density would apply to none: refused in one line
    when the scenario is read (issue 47: a dead key), so `tune` never meets it."""
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    with pytest.raises(ScenarioError, match=r"filter.process_noise_psd_ric_m2_s3 = \[1e-12, 1e-12, 1e-12\] applies "
                                            r"to no spacecraft"):
        apply_overrides(scenario, {"filter.process_noise_psd_ric_m2_s3": [1e-12, 1e-12, 1e-12]})
