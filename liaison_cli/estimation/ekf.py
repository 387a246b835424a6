"""Extended Kalman filter steps (Turan et al. 2022, Eq. 12, 21-24), numba-compiled, textbook names.

n = state size (6 per spacecraft). Measurements are processed one scalar at a time with a diagonal
R, which is algebraically the batch update (Eq. 21-23) and needs no matrix inverse.
"""

import numpy as np
from numba import njit


@njit(cache=True)
def predict_covariance(P, Phi, Q):
    """P_bar = Phi P Phi^T + Q (Eq. 12). P, Phi, Q: (n, n) -> (n, n)."""
    P_bar = Phi @ P @ Phi.T + Q
    return 0.5 * (P_bar + P_bar.T)


@njit(cache=True)
def update_scalar(dx, P, y, H, R):
    """One scalar measurement update in Joseph form.

    dx (n,): state correction accumulated so far (relative to the linearisation point);
    P (n, n); y: pre-fit residual Y - G(X*); H (n,): partials at X*; R: variance.
    Returns (dx (n,), P (n, n), innovation, S) where innovation = y - H dx and S = H P H^T + R.

    Joseph form P+ = (I - K H) P (I - K H)^T + K R K^T (cf. Eq. 23), evaluated without forming I - K H:
    with h = P H^T and A = P - K h^T, P+ = A - (h - K (S - R)) K^T + R K K^T, which is the same
    product regrouped (valid for any gain K), in O(n^2) instead of two n x n matrix products.
    """
    n = dx.shape[0]
    h = P @ H
    S = H @ h + R
    K = h / S  # K = P H^T (H P H^T + R)^-1 (Eq. 21)
    innovation = y - H @ dx
    P_new = np.empty((n, n))
    new_dx = np.empty(n)
    hs = S - R
    for i in range(n):
        new_dx[i] = dx[i] + K[i] * innovation  # Eq. 22, sequential form
        u_i = h[i] - K[i] * hs
        for j in range(n):
            P_new[i, j] = P[i, j] - K[i] * h[j] - u_i * K[j] + R * K[i] * K[j]
    for i in range(n):
        for j in range(i + 1, n):
            sym = 0.5 * (P_new[i, j] + P_new[j, i])
            P_new[i, j] = sym
            P_new[j, i] = sym
    return new_dx, P_new, innovation, S
