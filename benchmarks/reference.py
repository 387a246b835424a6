"""The plain reference EKF: the obvious implementation, used only as a yardstick for speed and accuracy.

scipy solve_ivp (DOP853, rtol 1e-10, atol 1e-12) once per measurement interval on state + STM, numpy EKF
update in Joseph form, no vectorisation, no JIT. Deliberately independent of liaison's numeric core: its
own CRTBP right-hand side, its own range partials.
"""

import numpy as np
from scipy.integrate import solve_ivp


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
