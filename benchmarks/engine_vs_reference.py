"""Seconds per 10-day EKF run: liaison's compiled engine vs a plain reference, same process, same inputs.

The reference is the obvious implementation, written here only as a yardstick: scipy solve_ivp
(DOP853, rtol 1e-10, atol 1e-12) once per measurement interval on state + STM, numpy EKF update with
Joseph form, no vectorisation, no JIT. Both filters get identical initial estimates and noisy
measurements (drawn by liaison's seeding), so their RMS errors must agree as well.

    python benchmarks/engine_vs_reference.py [--scenario scenarios/eml2_lunar.yaml] [--days 10]
"""

import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp

from liaison_cli.analysis.metrics import summary_rows
from liaison_cli.campaign.problem import M_PER_LU, M_S_PER_VU, prepare_problem
from liaison_cli.campaign.schema import apply_overrides, load_scenario
from liaison_cli.campaign.worker import draw_run_inputs
from liaison_cli.estimation.filter_loop import run_ekf


def _rhs_plain(t, y, mu):
    x, yy, z, vx, vy, vz = y[:6]
    r1 = np.sqrt((x + mu) ** 2 + yy**2 + z**2)
    r2 = np.sqrt((x - 1 + mu) ** 2 + yy**2 + z**2)
    acc = np.array(
        [
            2 * vy + x - (1 - mu) * (x + mu) / r1**3 - mu * (x - 1 + mu) / r2**3,
            -2 * vx + yy - (1 - mu) * yy / r1**3 - mu * yy / r2**3,
            -(1 - mu) * z / r1**3 - mu * z / r2**3,
        ]
    )
    d1 = np.array([x + mu, yy, z])
    d2 = np.array([x - 1 + mu, yy, z])
    g = (
        3 * (1 - mu) * np.outer(d1, d1) / r1**5
        + 3 * mu * np.outer(d2, d2) / r2**5
        - ((1 - mu) / r1**3 + mu / r2**3) * np.eye(3)
        + np.diag([1.0, 1.0, 0.0])
    )
    A = np.zeros((6, 6))
    A[:3, 3:] = np.eye(3)
    A[3:, :3] = g
    A[3, 4], A[4, 3] = 2.0, -2.0
    phi = y[6:].reshape(6, 6)
    return np.concatenate([y[3:6], acc, (A @ phi).ravel()])


def reference_ekf(problem, x0_hat, y_obs):
    """Plain EKF; returns (err (m, n), sigma (m, n)) like the engine."""
    m, n = problem.truth.shape
    n_sc = n // 6
    x_hat, P = x0_hat.copy(), problem.P0.copy()
    err = np.full((m, n), np.nan)
    sig = np.full((m, n), np.nan)
    err[0], sig[0] = x_hat - problem.truth[0], np.sqrt(np.diag(P))
    for k in range(1, m):
        x_bar = np.empty(n)
        Phi = np.zeros((n, n))
        for s in range(n_sc):
            y0 = np.concatenate([x_hat[6 * s : 6 * s + 6], np.eye(6).ravel()])
            sol = solve_ivp(_rhs_plain, (0.0, problem.dt_tu), y0, method="DOP853", rtol=1e-10, atol=1e-12,
                            args=(problem.mu,))
            x_bar[6 * s : 6 * s + 6] = sol.y[:6, -1]
            Phi[6 * s : 6 * s + 6, 6 * s : 6 * s + 6] = sol.y[6:, -1].reshape(6, 6)
        P = Phi @ P @ Phi.T + problem.Q
        dx = np.zeros(n)
        for l in range(len(problem.link_receiver)):
            r, t = 6 * problem.link_receiver[l], 6 * problem.link_transponder[l]
            d = x_bar[r : r + 3] - x_bar[t : t + 3]
            rho = np.linalg.norm(d)
            H = np.zeros(n)
            H[r : r + 3], H[t : t + 3] = d / rho, -d / rho
            R = problem.sigma_lu[l] ** 2
            S = H @ P @ H + R
            K = P @ H / S
            dx = dx + K * (y_obs[k, l] - rho - H @ dx)
            IKH = np.eye(n) - np.outer(K, H)
            P = IKH @ P @ IKH.T + R * np.outer(K, K)
        x_hat = x_bar + dx
        err[k], sig[k] = x_hat - problem.truth[k], np.sqrt(np.diag(P))
    return err, sig


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/eml2_lunar.yaml")
    parser.add_argument("--days", type=float, default=10.0)
    parser.add_argument("--reference-runs", type=int, default=1)
    parser.add_argument("--engine-runs", type=int, default=20)
    args = parser.parse_args()

    scenario, _ = load_scenario(args.scenario)
    problem = prepare_problem(apply_overrides(scenario, {"duration_days": args.days}))
    engine_args = lambda x0, y: (x0, problem.P0, problem.Q, problem.truth, y, problem.link_receiver,  # noqa: E731
                                 problem.link_transponder, problem.sigma_lu, problem.dt_tu, problem.substeps,
                                 problem.mu, problem.divergence_position_lu)
    t0 = time.perf_counter()
    run_ekf(*engine_args(*draw_run_inputs(problem, 0)))
    first_call = time.perf_counter() - t0  # cache load, or compile if the cache is cold

    engine_times, ref_times = [], []
    for run in range(args.engine_runs):
        x0, y = draw_run_inputs(problem, run)
        t0 = time.perf_counter()
        out = run_ekf(*engine_args(x0, y))
        engine_times.append(time.perf_counter() - t0)
        if run < args.reference_runs:
            t0 = time.perf_counter()
            ref_err, ref_sig = reference_ekf(problem, x0, y)
            ref_times.append(time.perf_counter() - t0)
            fast = summary_rows(problem.times_s, out[0], out[1], problem.spacecraft, M_PER_LU, M_S_PER_VU)[0]
            ref = summary_rows(problem.times_s, ref_err, ref_sig, problem.spacecraft, M_PER_LU, M_S_PER_VU)[0]
            for a, b in zip(fast, ref):
                print(f"run {run} {a['spacecraft']:>6}: RMS position engine {a['rms_position_m']:.3f} m, "
                      f"reference {b['rms_position_m']:.3f} m; velocity {1e3 * a['rms_velocity_m_s']:.4f} / "
                      f"{1e3 * b['rms_velocity_m_s']:.4f} mm/s")
    engine = float(np.median(engine_times))
    reference = float(np.median(ref_times))
    print(f"scenario {scenario.name}, {args.days:g} d, {problem.n_steps - 1} measurement epochs")
    print(f"engine first call (cache load or compile): {first_call:.2f} s")
    print(f"engine:    {1e3 * engine:8.1f} ms per run (median of {len(engine_times)})")
    print(f"reference: {1e3 * reference:8.1f} ms per run (median of {len(ref_times)})")
    print(f"speed-up:  {reference / engine:8.1f}x")


if __name__ == "__main__":
    main()
