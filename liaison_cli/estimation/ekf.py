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
    """
    n = dx.shape[0]
    PHt = P @ H
    S = H @ PHt + R
    K = PHt / S  # K = P H^T (H P H^T + R)^-1 (Eq. 21)
    innovation = y - H @ dx
    dx = dx + K * innovation  # Eq. 22, sequential form
    IKH = np.eye(n) - np.outer(K, H)
    # Joseph form (I - K H) P (I - K H)^T + K R K^T keeps P symmetric positive definite (cf. Eq. 23).
    P = IKH @ P @ IKH.T + R * np.outer(K, K)
    return dx, 0.5 * (P + P.T), innovation, S
