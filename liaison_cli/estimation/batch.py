"""Batch weighted least squares (002 §3, after Tapley, Schutz & Born ch. 4): the epoch state of every
spacecraft (plus any constant blocks) from all measurements of a span, iterated to convergence.

Per iteration (Gauss-Newton on the nonlinear residuals):
  X*(t_k) = propagate(x*)                        reference trajectory from the current epoch estimate
  y_k = Y_k - G(X*(t_k))                          observation residuals               (002 Eq. 25-26)
  H_k = G_X(X*(t_k)) Phi(t_k, t_0)                measurements mapped to the epoch    (002 Eq. 31-35)
  Lambda = sum H_k^T W_k H_k (+ P0^-1),  N = sum H_k^T W_k y_k (+ P0^-1 (x_bar - x*))
  Lambda dx = N                                   normal equations                    (002 Eq. 36)
  x* += dx, until the largest position correction is below the tolerance.
Phi comes from the dynamics interface (state + STM over an interval). `jacobian = JACOBIAN_FIRST` keeps the
first iteration's Phi (computed on the a-priori reference) for later iterations and propagates only the
state (modified Gauss-Newton: the same fixed point, since the residuals stay nonlinear; about 3x cheaper).

The normal equations are solved by Cholesky after symmetric equilibration, refused above an equilibrated
condition number of 1e12 (estimation.gauss_newton, which also holds the row accumulation, the a-priori
information and the convergence test this solve shares with the EKF's initial batch).

No residual editing here: the EKF's gate (filter.residual_gate_sigma) judges each measurement by its
pre-fit innovation against the filter's current covariance, which a batch does not have; a batch edits by
post-fit residuals between iterations against their RMS (e.g. GMAT's OLSE initial and multiplicative
sigmas), a different rule not implemented. The scenario schema refuses the gate with estimator: batch.
"""

from dataclasses import dataclass

import numpy as np
from numba import njit

from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.model import propagate_rk8_in_place
from liaison_cli.estimation.blocks import BLOCK_SPACECRAFT
from liaison_cli.estimation.filter_loop import (END_RECEIVER_STATE, END_SECOND_STATE, END_TRANSMITTER_STATE,
                                                shared_calls)
from liaison_cli.estimation.gauss_newton import (accumulate_row, add_apriori, conditioned_solve,
                                                 negligible_correction, position_indices)
from liaison_cli.measurements.registry import residual

JACOBIAN_EVERY = 0
JACOBIAN_FIRST = 1

BATCH_OK = "ok"
BATCH_NOT_CONVERGED = "not converged"
BATCH_ILL_CONDITIONED = "ill-conditioned normal equations"
BATCH_NONFINITE = "non-finite residuals"


@njit(cache=True)
def propagate_reference(x, block_kind, block_start, model, params, dt_tu, counts, n_epochs, with_stm, traj, phi,
                        t0_tu=0.0):
    """Reference trajectory from the epoch estimate x (n,): traj (n_epochs, n) holds every block's value at
    every epoch (spacecraft propagated, constants carried); with_stm also fills phi (n_epochs, B, 6, 6) with
    Phi(t_k, t_0) of every spacecraft block b, integrated on through the intervals."""
    n = x.shape[0]
    size = 42 if with_stm else 6
    y = np.zeros(size)
    k_scratch = np.empty((12, size))
    tmp = np.empty(size)
    for k in range(n_epochs):
        for i in range(n):
            traj[k, i] = x[i]  # constants are carried; spacecraft entries are overwritten below
    for b in range(block_kind.shape[0]):
        if block_kind[b] != BLOCK_SPACECRAFT:
            continue
        a = block_start[b]
        for i in range(size):
            y[i] = 0.0
        for i in range(6):
            y[i] = x[a + i]
            if with_stm:
                y[6 + 7 * i] = 1.0
        for k in range(n_epochs):
            if k > 0:
                propagate_rk8_in_place(model, params, y, t0_tu + (k - 1) * dt_tu, dt_tu, counts[k - 1], k_scratch,
                                       tmp)
            for i in range(6):
                traj[k, a + i] = y[i]
            if with_stm:
                for i in range(6):
                    for j in range(6):
                        phi[k, b, i, j] = y[6 + 6 * i + j]


@njit(cache=True)
def _row(c, k, traj, phi, block_of_start, known_states, channels, h, H, g_r, g_t, g_s, measurement_row):
    """Predicted value of channel c (channels: kernel_args.Channels) at epoch k and its row h (n,) of partials
    w.r.t. the epoch state: the EKF's measurement row at the reference (measurement_row, the shared
    filter_loop.measurement_row: value with modifiers, partials H (n,) w.r.t. the current states) mapped to
    the epoch by each estimated end's Phi(t_k, t_0) (constant blocks map as the identity); g_r, g_t, g_s (6,)
    are scratch for the ends' partials."""
    value = measurement_row(channels, c, traj[k], known_states[k], H, g_r, g_t, g_s)[0]
    for i in range(h.shape[0]):
        h[i] = H[i]
    ends = channels.ends[c]
    for column in (END_RECEIVER_STATE, END_TRANSMITTER_STATE, END_SECOND_STATE):
        end = ends[column]
        if end < 0 or (column != END_RECEIVER_STATE and end == ends[END_RECEIVER_STATE]) or (
                column == END_SECOND_STATE and end == ends[END_TRANSMITTER_STATE]):
            continue  # no estimated end, or one already mapped (H holds its partials summed)
        b = block_of_start[end]
        for j in range(6):
            acc = 0.0
            for i in range(6):
                acc += H[end + i] * phi[k, b, i, j]
            h[end + j] = acc
    return value


@njit(cache=True)
def accumulate_normal_equations(traj, phi, block_of_start, y_obs, known_states, channels, n_use, measurement_row):
    """Lambda (n, n), N (n,), and per channel the residual sum of squares and count over epochs 1..n_use-1
    (measurement_row: the shared filter_loop.measurement_row, kernel_args.SharedCalls)."""
    channel_kind, sigma = channels.kind, channels.sigma
    n = traj.shape[1]
    n_channels = y_obs.shape[1]
    lam = np.zeros((n, n))
    rhs = np.zeros(n)
    ss = np.zeros(n_channels)
    count = np.zeros(n_channels, dtype=np.int64)
    h, H = np.empty(n), np.zeros(n)
    g_r = np.empty(6)
    g_t = np.empty(6)
    g_s = np.empty(6)
    nz = np.empty(n, dtype=np.int64)
    for k in range(1, n_use):
        for c in range(n_channels):
            y = y_obs[k, c]
            if not np.isfinite(y):
                continue
            value = _row(c, k, traj, phi, block_of_start, known_states, channels, h, H, g_r, g_t, g_s,
                         measurement_row)
            r = residual(channel_kind[c], y, value)
            w = 1.0 / (sigma[c] * sigma[c])
            ss[c] += r * r
            count[c] += 1
            accumulate_row(lam, rhs, h, w, r, nz)
    return lam, rhs, ss, count


@njit(cache=True)
def postfit_residuals(traj, phi, block_of_start, y_obs, known_states, channels, P, n_use, measurement_row):
    """Residuals (m, C) of the final reference at every epoch with data (NaN elsewhere) and their predicted
    spread sqrt(sigma^2 - h P h^T) inside the span (sqrt(sigma^2 + h P h^T) after it, a prediction)."""
    channel_kind, sigma = channels.kind, channels.sigma
    m, n_channels = y_obs.shape
    n = traj.shape[1]
    out = np.full((m, n_channels), np.nan)
    spread = np.full((m, n_channels), np.nan)
    h, H = np.empty(n), np.zeros(n)
    g_r = np.empty(6)
    g_t = np.empty(6)
    g_s = np.empty(6)
    for k in range(1, m):
        for c in range(n_channels):
            y = y_obs[k, c]
            if not np.isfinite(y):
                continue
            value = _row(c, k, traj, phi, block_of_start, known_states, channels, h, H, g_r, g_t, g_s,
                         measurement_row)
            out[k, c] = residual(channel_kind[c], y, value)
            hph = 0.0  # h P h^T in element loops: `h @ P @ h` compiled numba's BLAS dot paths (0.5 s of a first batch)
            for i in range(n):
                acc = 0.0
                for j in range(n):
                    acc += P[i, j] * h[j]
                hph += h[i] * acc
            var = sigma[c] * sigma[c] + (-hph if k < n_use else hph)
            spread[k, c] = np.sqrt(max(var, 0.0))
    return out, spread


@dataclass(frozen=True, eq=False)
class BatchSolution:
    """x0 (n,) epoch estimate; P (n, n) its formal covariance; iterations; status (BATCH_*); condition:
    the equilibrated condition number of Lambda; residual_rms (C,) post-fit per channel (filter units);
    corrections: the largest position correction (LU) of each iteration."""

    x0: np.ndarray
    P: np.ndarray
    iterations: int
    status: str
    condition: float
    residual_rms: np.ndarray
    corrections: tuple


def solve_batch(x_apriori, P_apriori, y_obs, known_states, channels, layout, model, dynamics, counts, n_use,
                use_apriori=False, max_iterations=10, tolerance_lu=1e-9, jacobian=JACOBIAN_FIRST):
    """One batch solve over epochs 0..n_use-1 (epoch 0, at dynamics.t0_tu, is the solve epoch). Shapes:
    x_apriori (n,), P_apriori (n, n), y_obs (m, C), known_states (m, K, 6); channels, layout, dynamics:
    estimation.kernel_args (dynamics.substeps is the EKF's; the batch's RK8 takes counts (m - 1,) steps per
    interval); model: the dynamics model code.
    Returns (BatchSolution, traj (m, n), phi (m, B, 6, 6), residuals (m, C), spread (m, C)): the converged
    trajectory over all m epochs, Phi(t_k, t_0) of the last STM pass, and the post-fit residuals with their
    predicted spread (estimation.batch.postfit_residuals)."""
    block_kind, block_start = layout.kind, layout.start
    params, dt_tu, t0_tu = dynamics.params, dynamics.dt_tu, dynamics.t0_tu
    known_states = writable_c(known_states)  # as the shared measurement row is typed (filter_loop.shared_calls)
    n = x_apriori.shape[0]
    m = y_obs.shape[0]
    n_blocks = block_kind.shape[0]
    block_of_start = np.full(n, -1, dtype=np.int64)
    for b in range(n_blocks):
        block_of_start[block_start[b]] = b
    traj = np.empty((m, n))
    phi = np.zeros((m, n_blocks, 6, 6))
    info_apriori = np.linalg.inv(P_apriori) if use_apriori else None
    x = x_apriori.copy()
    position = position_indices(block_kind, block_start)
    corrections, status, cov, cond, iterations = [], BATCH_NOT_CONVERGED, None, np.nan, 0
    calls = shared_calls(channels, layout, dynamics)
    for iterations in range(1, max_iterations + 1):
        # The STM covers every epoch (the span and the prediction after it), so the frozen Phi also maps the
        # covariance forward; later iterations of the frozen-Jacobian method propagate the state only.
        with_stm = jacobian == JACOBIAN_EVERY or iterations == 1
        propagate_reference(x, block_kind, block_start, model, params, dt_tu, counts, m if with_stm else n_use,
                            with_stm, traj, phi, t0_tu)
        lam, rhs, _, _ = accumulate_normal_equations(traj, phi, block_of_start, y_obs, known_states, channels, n_use,
                                                     calls.measurement_row)
        if info_apriori is not None:
            lam, rhs = add_apriori(lam, rhs, info_apriori, x, x_apriori)
        if not (np.all(np.isfinite(lam)) and np.all(np.isfinite(rhs))):
            status = BATCH_NONFINITE
            break
        dx, cov, cond = conditioned_solve(lam, rhs)
        if dx is None:
            status = BATCH_ILL_CONDITIONED
            break
        x = x + dx
        corrections.append(float(np.max(np.abs(dx[position]))))
        if negligible_correction(dx[position], tolerance_lu):
            status = BATCH_OK
            break
    # The converged trajectory over every epoch, for errors and post-fit residuals (Phi as last computed).
    propagate_reference(x, block_kind, block_start, model, params, dt_tu, counts, m, False, traj, phi, t0_tu)
    P = cov if cov is not None else np.full((n, n), np.nan)
    post, spread = postfit_residuals(traj, phi, block_of_start, y_obs, known_states, channels, P, n_use,
                                     calls.measurement_row)
    with np.errstate(invalid="ignore"):
        rms = np.sqrt(np.nanmean(post[:n_use] ** 2, axis=0)) if n_use > 1 else np.full(y_obs.shape[1], np.nan)
    solution = BatchSolution(x, P, iterations, status, cond, rms, tuple(corrections))
    return solution, traj, phi, post, spread
