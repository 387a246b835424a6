"""The per-run EKF loop over measurement epochs (Turan et al. 2022, Eq. 10-24), compiled with numba.

Everything here is plain arrays: no Python objects in the inner loop, so one 10-day run costs tens of
milliseconds. The dynamics enter only through `rk4_state_stm`, the observable only through the range
model functions; the EKF algebra lives in `estimation.ekf`.
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.crtbp import rk4_state_stm
from liaison_cli.estimation.ekf import (
    normalized_error_squared,
    predict_covariance_block_diagonal,
    update_scalar,
)
from liaison_cli.dynamics.constants import SPEED_OF_LIGHT_LU_TU
from liaison_cli.measurements.range import geometric_range, geometric_range_gradient
from liaison_cli.measurements.los import azimuth_elevation, azimuth_elevation_gradients
from liaison_cli.measurements.range_rate import range_rate, range_rate_gradient

KIND_RANGE = 0
KIND_RANGE_RATE = 1
KIND_AZIMUTH = 2
KIND_ELEVATION = 3

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_COVARIANCE_NOT_POSITIVE = 2
STATUS_ERROR_BEYOND_BOUND = 3

STATUS_NAMES = {
    STATUS_OK: "ok",
    STATUS_NONFINITE: "diverged: non-finite state or covariance",
    STATUS_COVARIANCE_NOT_POSITIVE: "diverged: covariance not positive definite",
    STATUS_ERROR_BEYOND_BOUND: "diverged: position error beyond the scenario bound",
}


@njit(cache=True)
def run_ekf(
    x0_hat,
    P0,
    Q,
    truth,
    y_obs,
    link_receiver,
    link_transponder,
    channel_link,
    channel_kind,
    sigma_lu,
    dt_tu,
    substeps,
    mu,
    divergence_position_lu,
    light_time_model=False,
    n_sc=-1,
    bias_mode=0,
):
    """Run one EKF pass.

    x0_hat (n,) initial estimate, n = 6 * n_sc; P0 (n, n); Q (n, n) added at every step (Eq. 12);
    truth (m, n) true states at the m epochs t_k = k * dt_tu; link_receiver / link_transponder (L,)
    spacecraft indices. Measurements come in C scalar channels: channel_link (C,) the link of each,
    channel_kind (C,) 0 range (LU), 1 range-rate (LU/TU), 2 azimuth, 3 elevation (rad); y_obs (m, C)
    observed values (row 0 unused, NaN = no measurement); sigma_lu (C,) their 1-sigma. light_time_model: predict the two-way range as
    rho - rho_dot * rho / c (Eq. 14-15 to first order in the light time) instead of the geometric Eq. 17;
    the partials stay geometric (the correction changes them by ~1e-6 relative).

    Range biases: with bias_mode 1 (estimate) or 2 (consider) the state holds, after the 6 n_sc spacecraft
    states, one constant range bias per link (n = 6 n_sc + L; truth carries the true biases in those
    columns). The prediction adds the link's bias, H has 1 in its column. Estimate: a normal augmented
    state. Consider: its gain is zero (Schmidt-Kalman), so the spacecraft block of P is the consider
    covariance. NEES covers the spacecraft states, plus the biases when they are estimated.

    Returns (err (m, n), sigma (m, n), nees (m,), innovation (m, L), innovation_std (m, L), status,
    fail_step): err = x_hat - x_true, sigma = sqrt(diag P), both after the update at each epoch.
    Rows after a failure stay NaN.
    """
    m, n = truth.shape
    if n_sc < 0:
        n_sc = n // 6
    n_dyn = 6 * n_sc
    n_channels = channel_link.shape[0]
    n_gain = n_dyn if bias_mode == 2 else -1
    n_nees = n if bias_mode == 1 else n_dyn
    err = np.full((m, n), np.nan)
    sig = np.full((m, n), np.nan)
    nees = np.full(m, np.nan)
    innovations = np.full((m, n_channels), np.nan)
    innov_std = np.full((m, n_channels), np.nan)

    x_hat = x0_hat.copy()
    P = P0.copy()
    err[0] = x_hat - truth[0]
    for i in range(n):
        sig[0, i] = np.sqrt(P[i, i])
    work = np.empty((n_nees, n_nees))
    nees[0] = normalized_error_squared(err[0, :n_nees], P[:n_nees, :n_nees], work)

    x_bar = np.empty(n)
    Phi = np.zeros((n, n))
    H = np.zeros(n)
    for k in range(1, m):
        # Time update: reference trajectory and STM from the last estimate (Eq. 10-12).
        for s in range(n_sc):
            a = 6 * s
            xs, phis = rk4_state_stm(x_hat[a : a + 6], dt_tu, substeps, mu)
            x_bar[a : a + 6] = xs
            Phi[a : a + 6, a : a + 6] = phis
        for i in range(n_dyn, n):
            x_bar[i] = x_hat[i]  # biases are constant
        # A fresh output buffer: P may still alias the previous one if no measurement came in.
        P = predict_covariance_block_diagonal(P, Phi, Q, np.empty((n, n)), n_sc)

        # Measurement update, one scalar channel at a time, all linearised at x_bar (Eq. 13, 17, 20-24).
        dx = np.zeros(n)
        for c in range(n_channels):
            y_meas = y_obs[k, c]
            if not np.isfinite(y_meas):
                continue
            l = channel_link[c]
            kind = channel_kind[c]
            ra = 6 * link_receiver[l]
            ta = 6 * link_transponder[l]
            H[:] = 0.0
            if kind == KIND_RANGE:
                predicted = geometric_range(x_bar[ra : ra + 3], x_bar[ta : ta + 3])
                if light_time_model:
                    predicted -= range_rate(x_bar[ra : ra + 6], x_bar[ta : ta + 6]) * predicted / SPEED_OF_LIGHT_LU_TU
                g = geometric_range_gradient(x_bar[ra : ra + 3], x_bar[ta : ta + 3])
                H[ra : ra + 3] = g
                H[ta : ta + 3] = -g
                if bias_mode != 0:
                    predicted += x_bar[n_dyn + l]
                    H[n_dyn + l] = 1.0
            elif kind == KIND_RANGE_RATE:
                predicted = range_rate(x_bar[ra : ra + 6], x_bar[ta : ta + 6])
                g6 = range_rate_gradient(x_bar[ra : ra + 6], x_bar[ta : ta + 6])
                H[ra : ra + 6] = g6
                H[ta : ta + 6] = -g6
            else:
                az, el = azimuth_elevation(x_bar[ra : ra + 3], x_bar[ta : ta + 3])
                g_az, g_el = azimuth_elevation_gradients(x_bar[ra : ra + 3], x_bar[ta : ta + 3])
                g = g_az if kind == KIND_AZIMUTH else g_el
                predicted = az if kind == KIND_AZIMUTH else el
                H[ra : ra + 3] = g
                H[ta : ta + 3] = -g
            residual = y_meas - predicted
            if kind == KIND_AZIMUTH:  # wrap into (-pi, pi]
                residual = (residual + np.pi) % (2.0 * np.pi) - np.pi
            dx, P, innovation, S = update_scalar(dx, P, residual, H, sigma_lu[c] ** 2, n_gain)
            innovations[k, c] = innovation
            innov_std[k, c] = np.sqrt(S) if S > 0.0 else np.nan
        x_hat = x_bar + dx

        # Health checks: a diverged run stops here and reports why.
        finite = True
        for i in range(n):
            if not (np.isfinite(x_hat[i]) and np.isfinite(P[i, i])):
                finite = False
        if not finite:
            return err, sig, nees, innovations, innov_std, STATUS_NONFINITE, k
        for i in range(n):
            if P[i, i] <= 0.0:
                return err, sig, nees, innovations, innov_std, STATUS_COVARIANCE_NOT_POSITIVE, k
        e = x_hat - truth[k]
        err[k] = e
        for i in range(n):
            sig[k, i] = np.sqrt(P[i, i])
        nees[k] = normalized_error_squared(e[:n_nees], P[:n_nees, :n_nees], work)
        for s in range(n_sc):
            a = 6 * s
            if np.sqrt(e[a] ** 2 + e[a + 1] ** 2 + e[a + 2] ** 2) > divergence_position_lu:
                return err, sig, nees, innovations, innov_std, STATUS_ERROR_BEYOND_BOUND, k
    return err, sig, nees, innovations, innov_std, STATUS_OK, -1
