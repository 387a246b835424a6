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
    place. Returns (x_s (m, n), sigma_s (m, n), P^s_0 (n, n)); last < 0 (a run that failed): all NaN.

    Element loops in a fixed order, no BLAS or LAPACK call: numba's np.linalg.solve and matrix products compiled
    their shape-error paths (string formatting), 9 of the smoother's 12 s of compiling, and the numbers no
    longer depend on the BLAS kernel."""
    m, n = states.shape[0], states.shape[2]
    x_s = np.full((m, n), np.nan)
    sigma_s = np.full((m, n), np.nan)
    if last < 0:
        return x_s, sigma_s, np.full((n, n), np.nan)
    x_next = states[last, 0].copy()
    P_next = matrices[last, 1].copy()
    for i in range(n):
        x_s[last, i] = x_next[i]
        sigma_s[last, i] = np.sqrt(max(P_next[i, i], 0.0))
    gain, gain_t, lu = np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
    difference, work, P_now = np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
    x_now = np.empty(n)
    # Rows innermost throughout (contiguous): n = 30 costs what LAPACK and BLAS did, n = 12 less.
    for k in range(last - 1, -1, -1):
        P_bar, Phi, P_k = matrices[k + 1, 0], matrices[k + 1, 2], matrices[k, 1]
        # C_k^T = P_bar_{k+1}^{-1} Phi_{k+1} P_k (P_bar symmetric): solve P_bar C_k^T = Phi P_k.
        _product_into(Phi, P_k, gain_t)
        _solve_in_place(P_bar, gain_t, lu)
        for i in range(n):
            for j in range(n):
                gain[i, j] = gain_t[j, i]
                difference[i, j] = P_next[i, j] - P_bar[i, j]
        for i in range(n):  # x^s_k = x_k + C_k (x^s_{k+1} - x_bar_{k+1})
            acc = 0.0
            for j in range(n):
                acc += gain[i, j] * (x_next[j] - states[k + 1, 1, j])
            x_now[i] = states[k, 0, i] + acc
        _product_into(gain, difference, work)  # C_k (P^s_{k+1} - P_bar_{k+1})
        _product_into(work, gain_t, P_now)  # P^s_k = P_k + work C_k^T
        for i in range(n):
            for j in range(n):
                P_now[i, j] += P_k[i, j]
        for i in range(n):  # keep it symmetric against rounding over thousands of steps
            for j in range(i + 1, n):
                P_now[i, j] = P_now[j, i] = 0.5 * (P_now[i, j] + P_now[j, i])
        for i in range(n):
            x_s[k, i] = x_now[i]
            sigma_s[k, i] = np.sqrt(max(P_now[i, i], 0.0))
            x_next[i] = x_now[i]
            for j in range(n):
                P_next[i, j] = P_now[i, j]
    return x_s, sigma_s, P_next


@njit(cache=True)
def _product_into(A, B, out):
    """out (n, n) = A B, each row accumulated over l in index order (rows of B innermost: contiguous)."""
    n = A.shape[0]
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.0
        for l in range(n):
            a = A[i, l]
            for j in range(n):
                out[i, j] += a * B[l, j]


@njit(cache=True)
def _solve_in_place(A, X, lu):
    """X (n, r) <- A^{-1} X by Gaussian elimination with partial pivoting (LAPACK gesv's algorithm); lu (n, n)
    scratch. A singular A gives inf or NaN (the smoothed columns show it), never an exception in a worker."""
    n, r = A.shape[0], X.shape[1]
    for i in range(n):
        for j in range(n):
            lu[i, j] = A[i, j]
    for c in range(n):
        pivot_row, largest = c, abs(lu[c, c])
        for i in range(c + 1, n):
            if abs(lu[i, c]) > largest:
                pivot_row, largest = i, abs(lu[i, c])
        if pivot_row != c:
            for j in range(n):
                lu[c, j], lu[pivot_row, j] = lu[pivot_row, j], lu[c, j]
            for j in range(r):
                X[c, j], X[pivot_row, j] = X[pivot_row, j], X[c, j]
        for i in range(c + 1, n):
            factor = lu[i, c] / lu[c, c]
            for j in range(c + 1, n):
                lu[i, j] -= factor * lu[c, j]
            for j in range(r):
                X[i, j] -= factor * X[c, j]
    for c in range(n - 1, -1, -1):  # back substitution, row by row
        for l in range(c + 1, n):
            u = lu[c, l]
            for j in range(r):
                X[c, j] -= u * X[l, j]
        for j in range(r):
            X[c, j] /= lu[c, c]
