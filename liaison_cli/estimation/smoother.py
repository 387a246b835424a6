"""Fixed-interval smoothing of an EKF pass: the Rauch-Tung-Striebel (RTS) backward recursion.

Given, for epochs k = 0 .. m-1, the filter's updated estimate x_k and covariance P_k, and for k >= 1 the
predicted x_bar_k, P_bar_k and the state transition Phi_k from epoch k-1 to k (Rauch, Tung & Striebel
1965; Tapley, Schutz & Born, "Statistical Orbit Determination", §4.15.2; Bar-Shalom et al. §8.6):

    C_k     = P_k Phi_{k+1}^T P_bar_{k+1}^{-1}                      (the smoother gain)
    x^s_k   = x_k + C_k (x^s_{k+1} - x_bar_{k+1})
    P^s_k   = P_k + C_k (P^s_{k+1} - P_bar_{k+1}) C_k^T

starting from x^s_{m-1} = x_{m-1}, P^s_{m-1} = P_{m-1}. For the EKF the deviations are linearised about the
filter's own reference (x_bar_{k+1} = f(x_k)), the usual extended form. C_k is computed by a linear solve
with the symmetric P_bar_{k+1}, not an explicit inverse. On a linear system without process noise the
smoothed covariance at t0 equals the batch least-squares covariance (P0^-1 + sum H_k' R^-1 H_k)^-1 mapped
to t0 (tested). Memory: the forward pass keeps three (n, n) matrices per epoch; the backward pass only the
current P^s.

Arrays (filter units): the EKF's forward record, states (m, 2, n) = [x_hat, x_bar] and matrices
(m, 3, n, n) = [P_bar, P, Phi] (epoch 0's x_bar, P_bar and Phi unused). Returns x_s (m, n) and
sigma_s = sqrt(diag P^s) (m, n); rows after `last` stay NaN. A run that did not finish healthy is not
smoothed (last = -1: all NaN).
"""

import numpy as np
from numba import njit


@njit(cache=True)
def rts_smooth(states, matrices, last):
    """The RTS pass over epochs 0 .. last (module docstring) on the EKF's forward record: states (m, 2, n) =
    [x_hat, x_bar], matrices (m, 3, n, n) = [P_bar, P, Phi] per epoch (filter_loop.run_ekf's store), read in
    place. Returns (x_s (m, n), sigma_s (m, n), P^s_0 (n, n)); last < 0 (a run that failed): all NaN."""
    m, n = states.shape[0], states.shape[2]
    x_s = np.full((m, n), np.nan)
    sigma_s = np.full((m, n), np.nan)
    if last < 0:
        return x_s, sigma_s, np.full((n, n), np.nan)
    x_next = states[last, 0].copy()
    P_next = matrices[last, 1].copy()
    x_s[last] = x_next
    for i in range(n):
        sigma_s[last, i] = np.sqrt(max(P_next[i, i], 0.0))
    for k in range(last - 1, -1, -1):
        # C_k^T = P_bar_{k+1}^{-1} Phi_{k+1} P_k (P_bar symmetric), so C_k = (solve(P_bar, Phi P_k))^T.
        gain = np.linalg.solve(matrices[k + 1, 0], matrices[k + 1, 2] @ matrices[k, 1]).T
        x_now = states[k, 0] + gain @ (x_next - states[k + 1, 1])
        P_now = matrices[k, 1] + gain @ (P_next - matrices[k + 1, 0]) @ gain.T
        P_now = 0.5 * (P_now + P_now.T)  # keep it symmetric against rounding over thousands of steps
        x_s[k] = x_now
        for i in range(n):
            sigma_s[k, i] = np.sqrt(max(P_now[i, i], 0.0))
        x_next, P_next = x_now, P_now
    return x_s, sigma_s, P_next
