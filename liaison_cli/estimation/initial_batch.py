"""The EKF's initial orbit: a batch least-squares solution over the first hours of data, handed over with its
covariance (filter.initial_batch_hours). What operations do when the a priori is too poor for an EKF's first
linearisation: 004's 1,000 km / 100 m/s per axis is far outside the region where one TDoA/FDoA update at
a time, linearised at the predicted state, moves towards the truth.

The solve (Tapley, Schutz & Born 2004, §4.6, with a-priori information, i.e. the maximum a-posteriori
estimate under the Gaussian a priori):
  X*(t_k) = f(x*; t_0 -> t_k)              reference by the filter's own propagator (filter_loop.time_update)
  H_k = G_X(X*(t_k)) Phi(t_k, t_0)         each scalar measurement mapped to the window's first epoch
  (sum H_k' W H_k + P0^-1) dx = sum H_k' W y_k + P0^-1 (x_bar - x*)
  x* += dx (halved until J falls), until the largest position correction is below the tolerance or below
  1e-3 of its own sigma (a short window's cost is flat to round-off along its uncertain directions).
Epochs 0..n_window - 1 are the window (epoch 0 carries no measurement, as in the EKF). The hand-over at the
window's last epoch e: x(e) = X*(t_e), P(e) = Phi(e, 0) P_0|window Phi(e, 0)' + Q_e, with Q_e the process noise
accumulated over the window (Q_k = Phi_k Q_(k-1) Phi_k' + Q), so the EKF starts as if it had run with its
own process noise; the EKF then takes the measurements after epoch e. The window's own history (error, sigma)
is the batch solution mapped along its reference: a smoothed estimate, as the batch estimator reports its span.

Same propagator and measurement row as the EKF (time_update, measurement_row), so the hand-over is to the
filter's own dynamics at the same epoch. Clock blocks are propagated by their own transition; constant blocks
(biases, Delta-v) are carried. A manoeuvre inside the window is refused by the scenario (no burn here).
The row accumulation, the a-priori information, the equilibrated solve and the convergence test are the batch
estimator's (estimation.gauss_newton, which says why the two loops differ).
"""

from dataclasses import dataclass

import numpy as np
from numba import njit

from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.model import PROPAGATION_SIZE, STM_SIZE
from liaison_cli.estimation.filter_loop import shared_calls
from liaison_cli.estimation.gauss_newton import (accumulate_row, add_apriori, equilibrated_solve,
                                                 negligible_correction, position_indices)
from liaison_cli.measurements.registry import residual

INITIAL_BATCH_OK = "ok"


MAX_HALVINGS = 30


@dataclass(frozen=True)
class InitialBatchSettings:
    """first_window / max_window: epochs of the first and the longest window (a window's last epoch is the
    hand-over epoch); handover_sigma_lu: the window grows until every spacecraft's hand-over position 1-sigma
    (RSS) is below it; max_iterations per window; tolerance_lu: converged when no position correction
    exceeds it."""

    first_window: int
    max_window: int
    handover_sigma_lu: float
    max_iterations: int
    tolerance_lu: float


@njit(cache=True)
def reference_and_normal_equations(model, x0, y_obs, known_states, channels, layout, dynamics, Q, traj, phi, calls):
    """One Gauss-Newton pass over the window: traj (w, n) the reference from x0 (n,), phi (w, n, n) its
    Phi(t_k, t_0), and the normal equations Lambda (n, n), N (n,) of the measurements y_obs (w, C) at epochs
    1..w-1; also Q_w (n, n), the process noise accumulated to the last epoch, and the residual sum of squares
    weighted by 1/sigma^2 (a chi-square with as many degrees of freedom as measurements, at the truth).
    channels, layout, dynamics: estimation.kernel_args (dynamics.t0_tu is the window's first epoch); calls: the
    time update and measurement row by address (kernel_args.SharedCalls, filter_loop.shared_calls)."""
    channel_kind, sigma = channels.kind, channels.sigma
    dt_tu, t0_tu = dynamics.dt_tu, dynamics.t0_tu
    w, n = traj.shape
    n_channels = channel_kind.shape[0]
    lam = np.zeros((n, n))
    rhs = np.zeros(n)
    q_acc = np.zeros((n, n))
    q_tmp = np.empty((n, n))
    phi_step = np.eye(n)
    y_stm = np.empty(PROPAGATION_SIZE)
    work_stm = np.empty((5, STM_SIZE))
    H = np.zeros(n)
    h = np.zeros(n)
    g_receiver = np.empty(6)
    g_transmitter = np.empty(6)
    g_second = np.empty(6)
    nz = np.empty(n, dtype=np.int64)
    weighted_ss = 0.0
    for i in range(n):
        traj[0, i] = x0[i]
        for j in range(n):
            phi[0, i, j] = 1.0 if i == j else 0.0
    for k in range(1, w):
        calls.time_update(traj[k - 1], traj[k], phi_step, layout, model, dynamics, t0_tu + (k - 1) * dt_tu, y_stm,
                          work_stm)
        _propagate_products(phi_step, phi[k - 1], phi[k], q_acc, q_tmp, Q)
        for c in range(n_channels):
            y_meas = y_obs[k, c]
            if not np.isfinite(y_meas):
                continue
            predicted = calls.measurement_row(channels, c, traj[k], known_states[k], H, g_receiver, g_transmitter,
                                              g_second)[0]
            r = residual(channel_kind[c], y_meas, predicted)
            weight = 1.0 / (sigma[c] * sigma[c])
            weighted_ss += r * r * weight
            for j in range(n):  # the row mapped to the window's first epoch
                acc = 0.0
                for i in range(n):
                    acc += H[i] * phi[k, i, j]
                h[j] = acc
            accumulate_row(lam, rhs, h, weight, r, nz)
    return lam, rhs, q_acc, weighted_ss


@njit(cache=True, inline="always")
def _propagate_products(phi_step, phi_before, phi_now, q_acc, q_tmp, Q):
    """phi_now = phi_step phi_before; q_acc <- phi_step q_acc phi_step' + Q (element loops: n is small)."""
    n = Q.shape[0]
    for i in range(n):
        for j in range(n):
            acc = 0.0
            acc_q = 0.0
            for l in range(n):
                acc += phi_step[i, l] * phi_before[l, j]
                acc_q += phi_step[i, l] * q_acc[l, j]
            phi_now[i, j] = acc
            q_tmp[i, j] = acc_q
    for i in range(n):
        for j in range(n):
            acc = Q[i, j]
            for l in range(n):
                acc += q_tmp[i, l] * phi_step[j, l]
            q_acc[i, j] = acc


@dataclass(frozen=True, eq=False)
class InitialBatchResult:
    """status (INITIAL_BATCH_OK or why not); iterations; corrections_lu: the largest position correction of
    each iteration; x0 (n,), P0 (n, n): the solution at the window's first epoch; traj (w, n), sigma (w, n):
    its reference and mapped 1-sigma over the window, covariance (w, n, n) the mapped covariance; x_handover (n,), P_handover (n, n) at the last epoch;
    weighted_rss: the post-fit residual sum of squares over sigma^2 (its expectation is about the number of
    measurements less the number of states)."""

    status: str
    iterations: int
    corrections_lu: tuple
    traj: np.ndarray
    sigma: np.ndarray
    covariance: np.ndarray
    x_handover: np.ndarray
    P_handover: np.ndarray
    weighted_rss: float
    measurements: int


def solve_initial_batch(arrays, x_apriori, y_obs) -> InitialBatchResult:
    """The hand-over solution from the a priori x_apriori (n,) with covariance arrays.P0 on y_obs (m, C);
    arrays: the estimator's FilterArrays (its layout, channel tables, dynamics, Q, initial_batch settings).

    The window grows (first_window epochs, then doubling, up to max_window) until the hand-over position
    1-sigma (RSS, every spacecraft) is below handover_sigma_lu: each longer window starts from the shorter
    one's solution, so Gauss-Newton never linearises a long arc about the a priori (the nonlinearity grows
    with the arc). A window whose solve fails ends the search with that failure."""
    settings = arrays.initial_batch
    positions = position_indices(*arrays.layout.arrays()[:2]).reshape(-1, 3)  # one row per spacecraft
    x_start, result = x_apriori, None
    for w in window_lengths(settings):
        result = _solve_window(arrays, w, x_start, x_apriori, y_obs)
        if result.status != INITIAL_BATCH_OK:
            return result
        x_start = result.traj[0]
        worst = max(float(np.sqrt(np.trace(result.P_handover[p][:, p]))) for p in positions)
        if worst <= settings.handover_sigma_lu:
            break
    return result


def window_lengths(settings) -> list[int]:
    """Epoch counts of the growing windows: first_window, 2 (first_window - 1) + 1, ... up to max_window."""
    lengths, w = [], settings.first_window
    while w < settings.max_window:
        lengths.append(w)
        w = 2 * (w - 1) + 1
    return lengths + [settings.max_window]


def _solve_window(arrays, w, x_start, x_apriori, y_obs) -> InitialBatchResult:
    """Gauss-Newton with step halving on the window's epochs 0..w-1: the MAP cost
    J(x) = sum (r / sigma)^2 + (x - x_apriori)' P0^-1 (x - x_apriori) must fall at every accepted step (a full
    step that raises it, or leaves the propagation non-finite, is halved up to MAX_HALVINGS times)."""
    settings = arrays.initial_batch
    n = x_start.shape[0]
    traj, phi = np.empty((w, n)), np.empty((w, n, n))
    info_apriori = np.linalg.inv(arrays.P0)
    position = position_indices(*arrays.layout.arrays()[:2])
    args = [int(arrays.model), x_start, np.ascontiguousarray(y_obs[:w]),
            writable_c(arrays.known_states[:w]), arrays.channels(), arrays.block_layout(),
            arrays.dynamics(), arrays.dense_process_noise(), traj, phi,
            shared_calls(arrays.channels(), arrays.block_layout(), arrays.dynamics())]

    def linearise(x):
        args[1] = x
        lam, rhs, q_acc, weighted_ss = reference_and_normal_equations(*args)
        offset = x - x_apriori
        cost = weighted_ss + offset @ info_apriori @ offset
        return (*add_apriori(lam, rhs, info_apriori, x, x_apriori), q_acc, weighted_ss, cost)

    x = x_start.copy()
    lam, rhs, q_acc, weighted_ss, cost = linearise(x)
    corrections, status, cov = [], "not converged", None
    measured = int(np.isfinite(y_obs[1:w]).sum())
    for _ in range(settings.max_iterations):
        if not (np.isfinite(cost) and np.all(np.isfinite(lam))):
            status = "non-finite residuals or partials"
            break
        dx, cov = equilibrated_solve(lam, rhs)
        if dx is None:
            status = "normal equations not positive definite"
            break
        if _negligible(dx, cov, position, settings.tolerance_lu):  # at the minimum: a step this small
            x = x + dx                                                      # cannot be judged by the cost
            corrections.append(float(np.max(np.abs(dx[position]))))
            lam, rhs, q_acc, weighted_ss, cost = linearise(x)
            status = INITIAL_BATCH_OK
            _, cov = equilibrated_solve(lam, rhs)
            break
        for _ in range(MAX_HALVINGS + 1):
            trial = linearise(x + dx)
            if np.isfinite(trial[4]) and trial[4] <= cost * (1.0 + 1e-12):
                break
            dx = 0.5 * dx
        else:
            status = "no step lowers the cost"
            break
        x = x + dx
        lam, rhs, q_acc, weighted_ss, cost = trial
        corrections.append(float(np.max(np.abs(dx[position]))))
        if _negligible(dx, cov, position, settings.tolerance_lu):
            status = INITIAL_BATCH_OK
            _, cov = equilibrated_solve(lam, rhs)  # the covariance at the solution
            break
    if status != INITIAL_BATCH_OK or cov is None:
        status = status if status != INITIAL_BATCH_OK else "normal equations not positive definite"
        return InitialBatchResult(status, len(corrections), tuple(corrections), traj, np.full((w, n), np.nan),
                                  np.full((w, n, n), np.nan), np.full(n, np.nan), np.full((n, n), np.nan), np.nan,
                                  measured)
    mapped = np.einsum("kij,jl,kml->kim", phi, cov, phi)
    sigma = np.sqrt(np.abs(np.einsum("kii->ki", mapped)))
    P_handover = mapped[-1] + q_acc
    return InitialBatchResult(status, len(corrections), tuple(corrections), traj.copy(), sigma, mapped,
                              traj[-1].copy(), 0.5 * (P_handover + P_handover.T), float(weighted_ss), measured)


def _negligible(dx, cov, position, tolerance_lu) -> bool:
    """The position correction of dx below the tolerance, or below a small share of its own 1-sigma from cov
    (gauss_newton.negligible_correction)."""
    return negligible_correction(dx[position], tolerance_lu, np.sqrt(np.abs(np.diag(cov)[position])))
