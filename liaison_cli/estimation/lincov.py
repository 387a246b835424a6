"""Linear covariance analysis of the EKF along the truth: the estimation error split by error source.

To first order the EKF's error e = x_hat - x obeys, with the filter's own gains K and partials H
evaluated along the true trajectory (the linearisation LinCov tools such as ODTBX make):
  predict   e- = Phi e+ - d_dyn - w            Phi: the filter's STM over the step; w: truth process noise;
                                                d_dyn = x_k - f_filter(x_{k-1}), the filter's dynamics error
  update    e+ = (I - K H) e- + K (v + d_meas + b)   one scalar channel at a time, as the EKF does;
                                                v: measurement noise; d_meas = y_true - h_filter(x): the
                                                filter's measurement-model error (light time);
                                                b: an unmodelled (ignored) range bias
The error is linear in the sources, so its second moment is the sum of one part per source:
  random sources as covariances D (initial error, measurement noise, truth process noise),
  biases as sensitivities S = de/db (one column per link; covariance S Sigma_b S^T, mean S b_mean),
  deterministic mismatches as mean errors mu (measurement model, dynamics).
Pure numerics on plain arrays (compiled); campaign.studies.error_budget builds the inputs from a scenario.

The EKF's residual gate (filter.residual_gate_sigma, filter_loop.gated) is ignored here: whether a
measurement is edited depends on its realised innovation, which a linear analysis along the truth does not
have. LinCov is the ungated filter; a gate at k sigma on a consistent filter's clean data edits a share
2 (1 - Phi(k)) of the measurements (5.7e-7 at k = 5, 0.27 % at k = 3), so the two agree on clean data,
and LinCov says nothing about outliers.
"""

from collections import namedtuple

import numpy as np
from numba import njit

from liaison_cli.dynamics.model import PROPAGATION_SIZE, STM_SIZE
from liaison_cli.estimation.blocks import BLOCK_CONSTANT, BLOCK_SPACECRAFT
from liaison_cli.estimation.ekf import update_scalar_into
from liaison_cli.estimation.filter_loop import (
    apply_burn_covariance,
    apply_burn_rows,
    apply_burns,
    channel_states,
)
from liaison_cli.measurements.registry import predict_shared

PART_INITIAL, PART_NOISE, PART_PROCESS = 0, 1, 2
N_RANDOM_PARTS = 3

# What the truth does that the filter does not know (lincov_along_truth's docstring).
TruthErrors = namedtuple("TruthErrors", ["D_initial", "Q_true", "S0", "d_dyn_extra", "channel_bias_link"])


@njit(cache=True)
def _propagate_parts(D, S, mu_meas, mu_dyn, Phi, Q_true, d_dyn, block_kind, block_start, block_size, scratch,
                     work_block, predict_covariance):
    """Predict step of every part: D <- Phi D Phi^T (+ Q_true for the process part), S <- Phi S,
    mu <- Phi mu (minus the dynamics mismatch for mu_dyn); predict_covariance: the shared
    ekf.predict_covariance_into (kernel_args.SharedCalls), scratch (n, n) and work_block (6, 6) its scratch."""
    n = Phi.shape[0]
    zero = np.zeros((n, n))
    # Element loops, no array expressions or slice assignment: those made numba compile their shape-error
    # paths (string formatting), 10 s of `liaison errors`' first run.
    for p in range(D.shape[0]):
        q = Q_true if p == PART_PROCESS else zero
        predicted = predict_covariance(D[p], Phi, q, scratch, work_block, block_kind, block_start, block_size)
        for i in range(n):
            for j in range(n):
                D[p, i, j] = predicted[i, j]
    column = np.empty(n)
    for l in range(S.shape[1]):
        _apply_into(Phi, S[:, l], column)
        for i in range(n):
            S[i, l] = column[i]
    _apply_into(Phi, mu_meas, column)
    for i in range(n):
        mu_meas[i] = column[i]
    _apply_into(Phi, mu_dyn, column)
    for i in range(n):
        mu_dyn[i] = column[i] - d_dyn[i]


@njit(cache=True)  # a call, not inlined: four inlined copies were seconds of LinCov's compiling
def _apply_into(M, v, out):
    """out = M v (M (n, n), v and out (n,)), summed in column order."""
    n = M.shape[0]
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc += M[i, j] * v[j]
        out[i] = acc


@njit(cache=True)
def _update_parts(D, S, mu_meas, K, H, R_true, bias_column, d_meas):
    """Update step for one scalar channel with gain K (n,) and partials H (n,): e <- (I - K H) e + K input."""
    n = K.shape[0]
    g = np.empty(n)
    for p in range(D.shape[0]):
        _apply_into(D[p], H, g)
        hg = _dot(H, g)
        r = R_true if p == PART_NOISE else 0.0
        for i in range(n):
            for j in range(n):
                D[p, i, j] += -K[i] * g[j] - g[i] * K[j] + (hg + r) * K[i] * K[j]
    for l in range(S.shape[1]):
        hs = 0.0
        for i in range(n):
            hs += H[i] * S[i, l]
        for i in range(n):
            S[i, l] -= K[i] * hs
    if bias_column >= 0:
        for i in range(n):
            S[i, bias_column] += K[i]
    hm = _dot(H, mu_meas)
    for i in range(n):
        mu_meas[i] += K[i] * (d_meas - hm)


@njit(cache=True)  # a call, not inlined: fifteen inlined copies were seconds of LinCov's compiling
def _dot(a, b):
    acc = 0.0
    for i in range(a.shape[0]):
        acc += a[i] * b[i]
    return acc


@njit(cache=True, inline="always")
def _model_on_truth(truth_k, known_k, ends, kind, flags, g_r, g_t, g_s):
    """The filter's model of one channel on the true states of its ends at one epoch (partials into g_r, g_t
    and, for a three-end channel, g_s)."""
    x_r, x_t, x_s = channel_states(truth_k, known_k, ends)
    return predict_shared(kind, x_r, x_t, x_s, flags, g_r, g_t, g_s)


@njit(cache=True, inline="always")
def _burns_on_parts(linearisation, P, D, S, mu_meas, mu_dyn, burns, k):
    """A manoeuvre after epoch k: the filter's linearisation point (n,) and covariance P (n, n) and every
    error part (D (3, n, n), S (n, L), mu_meas, mu_dyn (n,)) take the map J (filter_loop.apply_burns); the
    truth takes its true Delta-v (the Delta-v columns of the truth)."""
    apply_burns(linearisation, P, burns, k)
    for p in range(N_RANDOM_PARTS):
        apply_burn_covariance(D[p], burns, k)
    apply_burn_rows(S, burns, k)
    _apply_burn_vector(mu_meas, burns, k)
    _apply_burn_vector(mu_dyn, burns, k)


@njit(cache=True, inline="always")
def _apply_burn_vector(v, burns, k):
    """v <- J v (n,) for the burns after epoch k (filter_loop.apply_burn_rows for one column, without a reshape:
    its error path cost seconds of compiling)."""
    for b in range(burns.shape[0]):
        if burns[b, 2] == k:
            d, velocity = burns[b, 0], burns[b, 1] + 3
            for i in range(3):
                v[velocity + i] += v[d + i]


@njit(cache=True, inline="always")
def _dynamics_mismatch(truth_k, x_bar, d_dyn_extra, Phi, layout):
    """d_dyn (n,) = x_k - f_filter(x_{k-1}) + the stated drifts on the spacecraft blocks, only the stated
    drifts d_dyn_extra (n,) on clocks and constants; Phi (n, n) gets the identity on constant blocks, which
    time_update leaves out."""
    block_kind, block_start, block_size = layout.kind, layout.start, layout.size
    d_dyn = np.empty(x_bar.shape[0])
    for i in range(x_bar.shape[0]):  # element loops: an array expression compiles its shape-error path
        d_dyn[i] = truth_k[i] - x_bar[i] + d_dyn_extra[i]
    for b in range(block_kind.shape[0]):
        if block_kind[b] != BLOCK_SPACECRAFT:  # clocks and constants: only the stated drifts
            for i in range(block_start[b], block_start[b] + block_size[b]):
                d_dyn[i] = d_dyn_extra[i]
                if block_kind[b] == BLOCK_CONSTANT:  # identity transition (time_update leaves it out)
                    Phi[i, i] = 1.0
    return d_dyn


@njit(cache=True, inline="always")
def _update_along_truth(k, truth, y_true, known_states, channels, n_gain, underweight, channel_bias_link, P,
                        P_spare, D, S, mu_meas, mu_dyn, vectors, measurement_row):
    """Epoch k's update, one scalar channel at a time as the EKF does: the filter's covariance P (its own
    update_scalar_into on a zero residual, dx staying zero) and, with its gain K from the P before it, every
    error part (_update_parts; mu_dyn <- mu_dyn - K H mu_dyn). vectors: dx, dx_spare, H, h, K (n,) and the
    ends' partials (6,) x 3, scratch. Returns (P, P_spare): the updated covariance and the spare."""
    channel_kind, sigma = channels.kind, channels.sigma
    dx, dx_spare, H, h, K, g_r, g_t, g_s = vectors
    n = P.shape[0]
    for c in range(channel_kind.shape[0]):
        if not np.isfinite(y_true[k, c]):
            continue
        predicted = measurement_row(channels, c, truth[k], known_states[k], H, g_r, g_t, g_s)[1]
        R = sigma[c] ** 2
        update_scalar_into(dx, P, 0.0, H, R, n_gain, underweight, dx_spare, P_spare, h, K)
        P, P_spare = P_spare, P
        _update_parts(D, S, mu_meas, K, H, R, channel_bias_link[c], y_true[k, c] - predicted)
        hm = _dot(H, mu_dyn)
        for i in range(n):
            mu_dyn[i] -= K[i] * hm
    return P, P_spare


@njit(cache=True, inline="always")
def _record_parts(k, P, D, S, mu_meas, mu_dyn, P_diag, D_diag, S_out, mu_meas_out, mu_dyn_out):
    """Epoch k's row of each output: diag P, diag of each random part, S, mu_meas and mu_dyn."""
    for i in range(P.shape[0]):
        P_diag[k, i] = P[i, i]
        mu_meas_out[k, i] = mu_meas[i]
        mu_dyn_out[k, i] = mu_dyn[i]
        for p in range(N_RANDOM_PARTS):
            D_diag[k, p, i] = D[p, i, i]
        for l in range(S.shape[1]):
            S_out[k, i, l] = S[i, l]


@njit(cache=True)
def lincov_along_truth(model, truth, y_true, known_states, channels, layout, dynamics, P0, Q, n_gain,
                       underweight, burns, truth_errors, calls):
    """The filter's covariance and the error parts at every epoch, after the update.

    model: the dynamics model code, read at run time (as the EKF's: filter_loop.run_ekf). truth (m, n): the true filter states (clock /
    bias columns may be zero: they enter linearly); y_true (m, C): noise-free, bias-free, clock-free true
    measurements (NaN: none); channels, layout, dynamics: as the EKF's (estimation.kernel_args; sigma is the
    filter's and the truth's 1-sigma); P0, Q (n, n) the filter's; n_gain, underweight: as the EKF's;
    truth_errors (TruthErrors): D_initial (n, n) the true initial error covariance; Q_true (n, n) the truth's
    process noise per step; S0 (n, L) the initial bias sensitivity (for biases that are filter states);
    d_dyn_extra (n,) a per-step deterministic truth increment the filter does not model (clock drifts);
    channel_bias_link (C,): the link whose unmodelled bias enters the channel (-1: none); calls: the time update,
    measurement row and covariance prediction by address (kernel_args.SharedCalls, filter_loop.shared_calls).

    Returns P_diag (m, n), D_diag (m, 3, n) for the initial / noise / process parts, S (m, n, L), mu_meas
    (m, n), mu_dyn (m, n). Each epoch is the module docstring's predict (time_update, the covariance
    prediction of Eq. 12 for P and _propagate_parts for the parts) then update (_update_along_truth).
    """
    block_kind, block_start, block_size = layout.kind, layout.start, layout.size
    dt_tu, t0_tu = dynamics.dt_tu, dynamics.t0_tu
    D_initial, Q_true, S0 = truth_errors.D_initial, truth_errors.Q_true, truth_errors.S0
    d_dyn_extra, channel_bias_link = truth_errors.d_dyn_extra, truth_errors.channel_bias_link
    m, n = truth.shape
    n_links = S0.shape[1]
    P = P0.copy()
    D = np.zeros((N_RANDOM_PARTS, n, n))
    for i in range(n):  # element loops: see _propagate_parts
        for j in range(n):
            D[PART_INITIAL, i, j] = D_initial[i, j]
    S = S0.copy()
    mu_meas = np.zeros(n)
    mu_dyn = np.zeros(n)
    P_diag, D_diag, S_out = np.empty((m, n)), np.empty((m, N_RANDOM_PARTS, n)), np.empty((m, n, n_links))
    mu_meas_out, mu_dyn_out = np.empty((m, n)), np.empty((m, n))
    x_bar, Phi, P_spare, scratch = np.empty(n), np.zeros((n, n)), np.empty((n, n)), np.empty((n, n))
    y_stm, work_stm, work_block = np.empty(PROPAGATION_SIZE), np.empty((5, STM_SIZE)), np.empty((6, 6))
    # dx: the filter's correction on noise-free data along the truth, stays zero; then dx_spare, H, h, K, g_*.
    vectors = (np.zeros(n), np.zeros(n), np.zeros(n), np.empty(n), np.empty(n), np.empty(6), np.empty(6),
               np.empty(6))
    for k in range(m):
        if k > 0:
            linearisation = truth[k - 1].copy()
            _burns_on_parts(linearisation, P, D, S, mu_meas, mu_dyn, burns, k - 1)
            calls.time_update(linearisation, x_bar, Phi, layout, model, dynamics, t0_tu + (k - 1) * dt_tu, y_stm,
                              work_stm)
            d_dyn = _dynamics_mismatch(truth[k], x_bar, d_dyn_extra, Phi, layout)
            P, P_spare = calls.predict_covariance(P, Phi, Q, P_spare, work_block, block_kind, block_start,
                                                  block_size), P
            _propagate_parts(D, S, mu_meas, mu_dyn, Phi, Q_true, d_dyn, block_kind, block_start, block_size,
                             scratch, work_block, calls.predict_covariance)
            P, P_spare = _update_along_truth(k, truth, y_true, known_states, channels, n_gain, underweight,
                                             channel_bias_link, P, P_spare, D, S, mu_meas, mu_dyn, vectors,
                                             calls.measurement_row)
        _record_parts(k, P, D, S, mu_meas, mu_dyn, P_diag, D_diag, S_out, mu_meas_out, mu_dyn_out)
    return P_diag, D_diag, S_out, mu_meas_out, mu_dyn_out


@njit(cache=True)
def filter_model_along_truth(truth, y_true, known_states, channel_kind, channel_ends, channel_flags):
    """The filter's measurement model evaluated on the truth, (m, C): what noise-free data would be if the
    truth obeyed the filter's model exactly (NaN where y_true has no measurement). Modifiers are left out,
    as they are in y_true."""
    m = truth.shape[0]
    n_channels = channel_kind.shape[0]
    out = np.full((m, n_channels), np.nan)
    g_r = np.empty(6)
    g_t = np.empty(6)
    g_s = np.empty(6)
    for k in range(m):
        for c in range(n_channels):
            if not np.isfinite(y_true[k, c]):
                continue
            out[k, c] = _model_on_truth(truth[k], known_states[k], channel_ends[c], channel_kind[c],
                                        channel_flags[c], g_r, g_t, g_s)
    return out
