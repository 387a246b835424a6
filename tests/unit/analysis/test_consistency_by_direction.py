"""Issue 34 items 1-2: consistency resolved by direction, and the verdict that reads the NEES.

The EKF kernel's direction record (filter_loop.record_directions) against a NumPy recomputation from the
covariance it stores for the smoother; the headline scenario in the paper's profile (001's geometric range
against a light-time truth) names the common time shift as its overconfident direction with the lag of
about the one-way light time, and the matched profile does not; the verdict flags pessimistic as well as
optimistic filters."""

import math

import numpy as np
import pytest

from liaison_cli.analysis.consistency import campaign_verdict, direction_columns, verdict
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.estimation.estimators import ekf_with_record
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.loading import apply_overrides
from liaison_cli.scenario.setup import prepare_problem
from liaison_cli.scenario.shipped import shipped_scenario

LIGHT_TIME_S = 0.2127  # EML2 - lunar orbiter, one way, at the scenario's start (issue 34)


def _history(overrides=None, days=3.0):
    scenario, _ = load_scenario(shipped_scenario("eml2_lunar.yaml"))
    scenario = apply_overrides(scenario, {"duration_days": days, **(overrides or {})})
    problem = prepare_problem(scenario)
    inputs = draw_run_inputs(problem, 0)
    history, states, matrices = ekf_with_record(problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth, True)
    return problem, inputs, history, matrices


def test_the_direction_record_is_the_whitened_error_along_each_direction():
    problem, inputs, history, matrices = _history()
    d = history.directions
    m = len(inputs.truth)
    assert d.stride == -(-m // 1000) and np.all(np.isnan(d.nees_spacecraft[1 :: d.stride]))  # sampled epochs only
    for k in (d.stride, 29 * d.stride, (m - 1) // d.stride * d.stride):
        P, e = matrices[k, 1], history.err[k]
        for s, a in enumerate(d.spacecraft_starts):
            block = slice(a, a + 6)
            assert d.nees_spacecraft[k, s] == pytest.approx(e[block] @ np.linalg.solve(P[block, block], e[block]),
                                                            rel=1e-9)
        lo, hi = k - 1, min(k + 1, len(inputs.truth) - 1)
        u = (inputs.truth[hi] - inputs.truth[lo]) / (hi - lo)
        projected = u @ np.linalg.solve(P, e)  # (L^-1 u)'(L^-1 e) = u' P^-1 e
        length = u @ np.linalg.solve(P, u)
        np.testing.assert_allclose(d.time_shift[k], [projected, length], rtol=1e-8)
        rho = inputs.truth[k, 6:9] - inputs.truth[k, 0:3]
        u = np.zeros(12)
        u[6:9], u[0:3] = rho / np.linalg.norm(rho), -rho / np.linalg.norm(rho)
        np.testing.assert_allclose(d.along_pair[k, 0], [u @ np.linalg.solve(P, e), u @ np.linalg.solve(P, u)],
                                   rtol=1e-8)
        for s, a in enumerate(d.spacecraft_starts):  # the position and velocity blocks, packed
            for half in range(2):
                block = P[a + 3 * half : a + 3 * half + 3, a + 3 * half : a + 3 * half + 3]
                packed = [block[0, 0], block[1, 1], block[2, 2], block[0, 1], block[0, 2], block[1, 2]]
                np.testing.assert_array_equal(d.covariance[k, s, 6 * half : 6 * half + 6], packed)


@pytest.mark.parametrize("range_model, lags", [("geometric", True), ("light_time", False)])
def test_the_paper_profile_lags_by_the_light_time_and_the_matched_one_does_not(range_model, lags):
    problem, _, history, _ = _history({"filter.range_model": range_model}, days=10.0)
    _, run = direction_columns(problem.times_s, history.directions, 86400.0, 2, ["EML2-Lunar"],
                               problem.scenario.measurement.interval_s)
    if lags:  # the whole lag is found, several sigma off, and it dominates the NEES
        assert run["time_shift_lag_s_settled"] == pytest.approx(LIGHT_TIME_S, rel=0.1)
        assert run["time_shift_bias_sigma_settled"] < -3.0 and run["time_shift_nees_settled"] > 10.0
    else:
        assert abs(run["time_shift_lag_s_settled"]) < 0.02 and run["time_shift_nees_settled"] < 3.0


def test_the_verdict_flags_both_sides_and_names_what_failed():
    ok, failed = verdict({"state": (0.95, 0.03)}, {"position": (1.05, 0.1), "velocity": (0.9, 0.1)})
    assert ok and failed == ""
    ok, failed = verdict({"state": (0.32, 0.68)}, {"position": (0.52, 0.05), "velocity": (1.0, 0.1)})
    assert not ok and "optimistic" in failed and "position err/sigma 0.52 +- 0.05 < 0.67: pessimistic" in failed
    ok, failed = verdict({"state": (0.93, 0.01)}, {"position": (2.0, 0.2), "velocity": (1.0, 0.1)})
    assert not ok and failed == "position err/sigma 2.00 +- 0.20 > 1.5: optimistic"
    # A ratio interval that reaches the allowed range passes: Monte Carlo noise is not a failure.
    assert verdict({}, {"position": (1.6, 0.2), "velocity": (1.0, 0.1)})[0]


def test_the_campaign_ratio_interval_shrinks_with_the_run_count():
    rng = np.random.default_rng(5)
    widths = []
    for runs in (5, 20, 80):
        sigma = np.full(runs, 100.0)
        error = sigma * np.sqrt(rng.chisquare(12, runs) / 12)  # consistent: mean e^2 = mean s^2
        out = campaign_verdict({"rms_position_settled_m": error, "sigma_position_settled_m": sigma,
                                "rms_velocity_settled_m_s": error, "sigma_velocity_settled_m_s": sigma})
        assert out["consistent_settled"] and abs(out["position_error_to_sigma_settled"] - 1) < 0.3
        widths.append(out["position_error_to_sigma_halfwidth"])
    assert widths[0] > widths[1] > widths[2] > 0
    # One run: no spread to measure, a point test (a ratio of 3 fails, as the run's own verdict says).
    one = campaign_verdict({"rms_position_settled_m": [3.0], "sigma_position_settled_m": [1.0],
                            "rms_velocity_settled_m_s": [1.0], "sigma_velocity_settled_m_s": [1.0]})
    assert one["position_error_to_sigma_halfwidth"] == 0.0 and not one["consistent_settled"]
    # Runs are paired: a run missing its sigma is left out whole, not matched with another run's.
    paired = campaign_verdict({"rms_position_settled_m": [1.0, 2.0, 3.0], "sigma_position_settled_m": [1.0, np.nan, 3.0],
                               "rms_velocity_settled_m_s": [1.0], "sigma_velocity_settled_m_s": [1.0]})
    assert paired["position_error_to_sigma_settled"] == pytest.approx(1.0)


def test_ric_components_are_a_rotation_of_the_3d_figures(monkeypatch):
    """Per spacecraft, the RIC axes are orthonormal with R away from the nearer primary, so the settled error
    RMS and sigma RMS of the three axes add in quadrature to the 3-D figures of the same epochs (every epoch
    recorded here: the record's stride set to 1)."""
    from liaison_cli.analysis.ric import primaries_lu, ric_axes
    from liaison_cli.campaign.engine.worker import execute_run, RunTask
    from liaison_cli.estimation import kernel_args

    monkeypatch.setattr(kernel_args, "MAX_DIRECTION_SAMPLES", 10**9)

    problem, inputs, _, _ = _history(days=3.0)
    row = execute_run(problem, RunTask(0)).summary[1]  # the lunar orbiter
    for kind, unit in (("position", "m"), ("velocity", "m_s")):
        for stat in ("rms", "sigma"):
            parts = sum(row[f"{stat}_{axis}_{kind}_settled_{unit}"] ** 2 for axis in ("radial", "intrack", "crosstrack"))
            assert math.sqrt(parts) == pytest.approx(row[f"{stat}_{kind}_settled_{unit}"], rel=1e-9)
    primaries = primaries_lu(problem.mu, {}, problem.times_s)
    lunar = inputs.truth[:, 6:12]
    axes = ric_axes(lunar[:, :3], lunar[:, 3:], primaries, np.zeros_like(primaries))
    np.testing.assert_allclose(np.einsum("kij,klj->kil", axes, axes), np.broadcast_to(np.eye(3), axes.shape), atol=1e-12)
    assert np.all(np.einsum("kj,kj->k", axes[:, 0], lunar[:, :3] - primaries[:, 1]) > 0)  # the Moon is nearer
