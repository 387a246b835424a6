"""The RTS smoother (issue 26, item 7) on a linear-Gaussian system, against the batch least-squares solution
it must equal when there is no process noise: smoothed covariance and estimate at t0 within 1e-6 relative."""

import numpy as np

from liaison_cli.estimation.smoother import rts_smooth


def _linear_system(seed=3, m=60, n=6, dt=0.7):
    """A double integrator in 3 axes with a weak spring (so Phi is not trivial), scalar range-like
    measurements along changing directions."""
    rng = np.random.default_rng(seed)
    A = np.zeros((n, n))
    A[:3, 3:] = np.eye(3)
    A[3:, :3] = -0.05 * np.eye(3)
    from scipy.linalg import expm

    phi = expm(A * dt)
    H = rng.standard_normal((m, n)) * np.array([1, 1, 1, 0.2, 0.2, 0.2])
    R = 0.3**2
    P0 = np.diag([4.0] * 3 + [0.5] * 3)
    x_true0 = rng.multivariate_normal(np.zeros(n), P0)
    truth = [x_true0]
    for _ in range(1, m):
        truth.append(phi @ truth[-1])
    truth = np.array(truth)
    y = np.einsum("kn,kn->k", H, truth) + 0.3 * rng.standard_normal(m)
    return phi, H, R, P0, y


def _kalman(phi, H, R, P0, y, Q):
    m, n = H.shape
    x_hat, x_bar = np.zeros((m, n)), np.zeros((m, n))
    P_upd, P_pred, Phi = np.zeros((m, n, n)), np.zeros((m, n, n)), np.zeros((m, n, n))
    x, P = np.zeros(n), P0.copy()
    for k in range(m):
        if k:
            x, P = phi @ x, phi @ P @ phi.T + Q
            x_bar[k], P_pred[k], Phi[k] = x, P, phi
        h = H[k]
        S = h @ P @ h + R
        K = P @ h / S
        x = x + K * (y[k] - h @ x)
        P = (np.eye(n) - np.outer(K, h)) @ P @ (np.eye(n) - np.outer(K, h)).T + R * np.outer(K, K)
        x_hat[k], P_upd[k] = x, P
    return x_hat, x_bar, P_upd, P_pred, Phi


def _record(x_hat, x_bar, P_upd, P_pred, Phi):
    """The forward record as filter_loop.run_ekf stores it: [x_hat, x_bar] and [P_bar, P, Phi] per epoch."""
    return np.stack([x_hat, x_bar], axis=1), np.ascontiguousarray(np.stack([P_pred, P_upd, Phi], axis=1))


def test_smoothed_start_equals_the_batch_solution_without_process_noise():
    phi, H, R, P0, y = _linear_system()
    m, n = H.shape
    x_hat, x_bar, P_upd, P_pred, Phi = _kalman(phi, H, R, P0, y, np.zeros((n, n)))
    x_s, sigma_s, P_s0 = rts_smooth(*_record(x_hat, x_bar, P_upd, P_pred, Phi), m - 1)
    # Batch: every measurement mapped to t0, prior mean 0 with P0.
    mapped = np.array([H[k] @ np.linalg.matrix_power(phi, k) for k in range(m)])
    information = np.linalg.inv(P0) + mapped.T @ mapped / R
    P_batch = np.linalg.inv(information)
    x_batch = P_batch @ (mapped.T @ y / R)
    np.testing.assert_allclose(P_s0, P_batch, rtol=1e-6, atol=1e-6 * np.abs(P_batch).max())
    np.testing.assert_allclose(x_s[0], x_batch, rtol=1e-6, atol=1e-6 * np.abs(x_batch).max())
    np.testing.assert_allclose(sigma_s[0], np.sqrt(np.diag(P_batch)), rtol=1e-6)
    # At the last epoch the smoother is the filter; elsewhere its sigma never exceeds the filter's.
    np.testing.assert_array_equal(x_s[-1], x_hat[-1])
    assert np.all(sigma_s <= np.sqrt(np.einsum("kii->ki", P_upd)) * (1 + 1e-9))


def test_with_process_noise_the_smoother_is_between_filter_and_truth_on_average():
    """Monte Carlo on the same system with process noise: the smoothed error's mean square matches the
    smoothed covariance (consistency) and is below the filter's."""
    phi, H, R, P0, _ = _linear_system()
    m, n = H.shape
    Q = np.diag([1e-3] * 3 + [1e-3] * 3)
    rng = np.random.default_rng(11)
    sq_s, sq_f, var_s = np.zeros((m, n)), np.zeros((m, n)), None
    runs = 300
    for _ in range(runs):
        truth = [rng.multivariate_normal(np.zeros(n), P0)]
        for _k in range(1, m):
            truth.append(phi @ truth[-1] + rng.multivariate_normal(np.zeros(n), Q))
        truth = np.array(truth)
        y = np.einsum("kn,kn->k", H, truth) + np.sqrt(R) * rng.standard_normal(m)
        x_hat, x_bar, P_upd, P_pred, Phi = _kalman(phi, H, R, P0, y, Q)
        x_s, sigma_s, _ = rts_smooth(*_record(x_hat, x_bar, P_upd, P_pred, Phi), m - 1)
        sq_s += (x_s - truth) ** 2
        sq_f += (x_hat - truth) ** 2
        var_s = sigma_s**2
    ratio = (sq_s / runs).mean(axis=0) / var_s.mean(axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.2)), ratio
    assert (sq_s.sum() < 0.8 * sq_f.sum())


def test_the_smoother_in_a_campaign_is_consistent_and_better_than_the_filter():
    """smoke with matched models and the RTS pass: over 20 runs the smoothed error RMS matches the smoothed
    sigma RMS, and it is below the filter's; at the last epoch smoothing changes nothing."""
    import math

    from liaison_cli.campaign.engine import results as results_module
    from liaison_cli.campaign.engine.runner import run_campaign
    from liaison_cli.scenario.loading import apply_overrides, load_scenario
    from tests.conftest import SCENARIOS

    scenario = apply_overrides(load_scenario(SCENARIOS / "smoke.yaml")[0], {
        "initial_error.draw": "from_covariance", "measurement.light_time": False,
        "spacecraft.1.process_noise_accel_m_s2": 1e-7, "filter.smoother": "rts"})
    result = run_campaign(scenario, runs=20, jobs=1, progress=False)
    table = results_module.summary_table(result)
    for _, group in table.groupby("spacecraft"):
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            ratio = math.sqrt((group[f"rms_{kind}_smoothed_{unit}"] ** 2).mean()
                              / (group[f"sigma_{kind}_smoothed_{unit}"] ** 2).mean())
            assert 0.75 <= ratio <= 1.3, (kind, ratio)
            assert group[f"rms_{kind}_smoothed_{unit}"].mean() < group[f"rms_{kind}_{unit}"].mean()
    norms = result.outcomes[0].norms
    assert norms["position_error_smoothed_m"][-1].tolist() == norms["position_error_m"][-1].tolist()
    assert "position_error_smoothed_m" not in run_campaign(
        apply_overrides(scenario, {"filter.smoother": "none"}), runs=1, jobs=1, progress=False).outcomes[0].norms


def test_the_smoother_is_refused_where_it_does_not_apply(tmp_path):
    from tests.conftest import assert_one_line_error, edited_scenario, run_cli_in_process

    path = edited_scenario(tmp_path, "bias_eml2_lunar.yaml", "  bias: consider", "  bias: consider\n  smoother: rts")
    assert_one_line_error(run_cli_in_process("run", path, "--output", tmp_path / "o"), path,
                          ["filter.smoother = 'rts' with filter.bias = 'consider'"])
