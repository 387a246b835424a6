"""The per-run EKF loop over measurement epochs (Turan et al. 2022, Eq. 10-24), compiled with numba.

Everything here is plain arrays: no Python objects in the inner loop, so one 10-day run costs tens of
milliseconds. The loop knows the state only as a layout of blocks (estimation.blocks), the dynamics only
through `dynamics.model.propagate_state_stm_into` (a model code + parameters), and the measurements only
through `measurements.registry.predict` / `residual` plus each channel's table of
ends and modifiers. The EKF algebra lives in `estimation.ekf`. The EKF, LinCov, the initial batch and the batch
call the time update, the measurement row and the covariance prediction by address (`shared_calls`,
`liaison_cli.compiled_calls`): one compiled copy of each, not one inside every estimator.
"""

import numpy as np
from numba import njit, types

from liaison_cli.compiled_calls import shared_call
from liaison_cli.dynamics.model import (PROPAGATION_SIZE, STM_SIZE, propagate_parameter_into,
                                       propagate_state_stm_into)
from liaison_cli.estimation.blocks import (BLOCK_CLOCK, BLOCK_CONSTANT, BLOCK_EMPIRICAL, BLOCK_PARAMETER,
                                          BLOCK_SPACECRAFT)
from liaison_cli.estimation.ekf import apply_update_into, nees_into, predict_covariance_into, prefit_into
from liaison_cli.estimation.kernel_args import Buffers, SharedCalls
from liaison_cli.estimation.process_noise import gauss_markov_gains
from liaison_cli.estimation.ric_noise import step_process_noise
from liaison_cli.measurements.registry import predict, residual

STATUS_OK = 0
STATUS_NONFINITE = 1
STATUS_COVARIANCE_NOT_POSITIVE = 2
STATUS_ERROR_BEYOND_BOUND = 3

STATUS_NAMES = {
    STATUS_OK: "ok",
    STATUS_NONFINITE: "diverged: non-finite state, covariance or innovation",
    STATUS_COVARIANCE_NOT_POSITIVE: "diverged: covariance not positive definite",
    STATUS_ERROR_BEYOND_BOUND: "diverged: position error beyond the scenario bound",
}

# Columns of `channel_ends`: the receiving end, the transmitting (or transponding) end and a three-end
# channel's second receiver (TDoA, FDoA), each either an estimated spacecraft (offset of its 6-state block
# in x) or a known participant (row of known_states); -1 in both columns of an end: no such end.
END_RECEIVER_STATE, END_RECEIVER_KNOWN, END_TRANSMITTER_STATE, END_TRANSMITTER_KNOWN = 0, 1, 2, 3
END_SECOND_STATE, END_SECOND_KNOWN = 4, 5


@njit(cache=True, inline="always")
def _end_state(x, known_k, state_offset, known_index):
    if state_offset >= 0:
        return x[state_offset : state_offset + 6]
    return known_k[known_index]


@njit(cache=True, inline="always")
def channel_states(x, known_k, ends):
    """(x_receiver, x_transmitter, x_second) (6,) each of a channel with `ends` (6,) (see END_*), from the
    filter states x (n,) and the known participants' states at the epoch known_k (K, 6); a two-end channel's
    x_second is its receiver's (unused by its kind)."""
    x_r = _end_state(x, known_k, ends[END_RECEIVER_STATE], ends[END_RECEIVER_KNOWN])
    x_t = _end_state(x, known_k, ends[END_TRANSMITTER_STATE], ends[END_TRANSMITTER_KNOWN])
    if ends[END_SECOND_STATE] < 0 and ends[END_SECOND_KNOWN] < 0:
        return x_r, x_t, x_r
    return x_r, x_t, _end_state(x, known_k, ends[END_SECOND_STATE], ends[END_SECOND_KNOWN])


@njit(cache=True, inline="always")
def scatter_partials(H, ends, g_receiver, g_transmitter, g_second):
    """H (n,) = 0 but the partials of the estimated ends at their state offsets (ends sharing a block add)."""
    H[:] = 0.0
    for i in range(6):  # element loops: see time_update
        if ends[END_RECEIVER_STATE] >= 0:
            H[ends[END_RECEIVER_STATE] + i] += g_receiver[i]
        if ends[END_TRANSMITTER_STATE] >= 0:
            H[ends[END_TRANSMITTER_STATE] + i] += g_transmitter[i]
        if ends[END_SECOND_STATE] >= 0:
            H[ends[END_SECOND_STATE] + i] += g_second[i]


@njit(cache=True)  # a call, not inlined: compiled once and shared by the EKF, the initial batch and LinCov
def measurement_row(channels, c, x, known_k, H, g_receiver, g_transmitter, g_second):
    """Channel c's model at the states x (n,) (known ends from known_k (K, 6)): returns (its value with the
    modifiers added one by one, its value without them) and writes its row of partials into H (n,), the ends'
    partials (g_* (6,), scratch; measurements.registry.predict) scattered to their state offsets plus each
    modifier's coefficient at its state (bias and clock modifiers: value += coeff * x[index]). The one
    measurement row of the EKF, the initial batch and LinCov (which compares the value without modifiers with
    its data)."""
    channel_kind, channel_ends, channel_flags = channels.kind, channels.ends, channels.flags
    channel_mod_index, channel_mod_coeff = channels.mod_index, channels.mod_coeff
    ends = channel_ends[c]
    x_r, x_t, x_s = channel_states(x, known_k, ends)
    value = predict(channel_kind[c], x_r, x_t, x_s, channel_flags[c], g_receiver, g_transmitter, g_second)
    scatter_partials(H, ends, g_receiver, g_transmitter, g_second)
    modified = value
    for j in range(channel_mod_index.shape[1]):
        index = channel_mod_index[c, j]
        if index >= 0:
            modified += channel_mod_coeff[c, j] * x[index]
            H[index] += channel_mod_coeff[c, j]
    return modified, value


def shared_calls(channels, layout, dynamics) -> SharedCalls:
    """The time update, the measurement row and the covariance prediction (ekf.predict_covariance_into) as
    compiled_calls.SharedCall arguments for the estimators' bodies (kernel_args.SharedCalls), typed for these
    groups: each body calls their one cached copy by address instead of carrying its own (compiled_calls)."""
    return SharedCalls(shared_time_update(layout, dynamics), shared_measurement_row(channels),
                       shared_covariance_prediction(layout))


def shared_time_update(layout, dynamics):
    """time_update as a SharedCall (shared_calls)."""
    n = np.empty(1)
    return shared_call(time_update, types.none, n, n, np.empty((1, 1)), layout, 0, dynamics, 0.0,
                       np.empty(PROPAGATION_SIZE), np.empty((5, STM_SIZE)))


def shared_measurement_row(channels):
    """measurement_row as a SharedCall (shared_calls)."""
    n = np.empty(1)
    return shared_call(measurement_row, types.UniTuple(types.float64, 2), channels, 0, n, np.empty((1, 6)), n,
                       np.empty(6), np.empty(6), np.empty(6))


def shared_covariance_prediction(layout):
    """ekf.predict_covariance_into as a SharedCall (shared_calls)."""
    nn, blocks = np.empty((1, 1)), layout.kind
    return shared_call(predict_covariance_into, types.float64[:, ::1], nn, nn, nn, nn, nn, blocks, blocks, blocks)


@njit(cache=True)
def apply_burns(x, P, burns, k):
    """Impulsive manoeuvres after epoch k: each burn row (Delta-v block start, spacecraft block start, epoch
    index) adds the Delta-v states to the spacecraft's velocity, x <- J x and P <- J P J^T with
    J = I + (the Delta-v columns into the velocity rows)."""
    for b in range(burns.shape[0]):  # x <- J x (element loops: a reshape compiles its error path)
        if burns[b, 2] == k:
            for i in range(3):
                x[burns[b, 1] + 3 + i] += x[burns[b, 0] + i]
    apply_burn_covariance(P, burns, k)


@njit(cache=True)
def apply_burn_covariance(P, burns, k):
    """P <- J P J^T for the burns after epoch k (apply_burns)."""
    apply_burn_rows(P, burns, k)  # J P
    for b in range(burns.shape[0]):  # (J P) J^T
        if burns[b, 2] != k:
            continue
        d, v = burns[b, 0], burns[b, 1] + 3
        for i in range(P.shape[0]):
            for j in range(3):
                P[i, v + j] += P[i, d + j]


@njit(cache=True)
def apply_burn_rows(M, burns, k):
    """M <- J M for the burns after epoch k (M (n, L): sensitivities, or the rows of a covariance)."""
    for b in range(burns.shape[0]):
        if burns[b, 2] != k:
            continue
        d, v = burns[b, 0], burns[b, 1] + 3
        for i in range(3):
            for j in range(M.shape[1]):
                M[v + i, j] += M[d + i, j]


@njit(cache=True)  # a call, not inlined: compiled once and shared by the EKF, the initial batch and LinCov
def time_update(x_hat, x_bar, Phi, layout, model, dynamics, t_tu, y, work):
    """x_bar = f(x_hat) (n,) over one interval from t_tu, block by block of the layout (kernel_args.BlockLayout)
    with the model code and its Dynamics group (kernel_args): the spacecraft and clock blocks of Phi (n, n)
    (Eq. 10-11), the identity on parameter blocks and, for a spacecraft with a dynamics parameter
    (layout.parameter >= 0), the column gamma = d x_spacecraft / d parameter that couples them
    (estimation.blocks); an empirical-acceleration block (time constant dynamics.empirical_tau_tu) decays and
    moves its spacecraft (_empirical_update; spacecraft blocks come first in a layout, so their x_bar is there
    to add to). y (PROPAGATION_SIZE,) and work (5, STM_SIZE): scratch for the state + STM propagation."""
    block_kind, block_start, block_size, block_parameter = layout.kind, layout.start, layout.size, layout.parameter
    model_params, dt_tu = dynamics.params, dynamics.dt_tu
    empirical_tau_tu = dynamics.empirical_tau_tu
    for b in range(block_kind.shape[0]):
        a, size = block_start[b], block_size[b]
        if block_kind[b] == BLOCK_SPACECRAFT:
            substeps = dynamics.substeps[b]  # this spacecraft's own step (scenario.integration_steps)
            p = block_parameter[b]
            if p >= 0:  # flown with its own parameter's value; the coupling column goes into Phi
                propagate_parameter_into(model, model_params, x_hat[p], x_hat[a : a + 6], t_tu, dt_tu, substeps,
                                         y, work)
                for i in range(6):
                    Phi[a + i, p] = y[STM_SIZE + i]
            else:
                propagate_state_stm_into(model, model_params, x_hat[a : a + 6], t_tu, dt_tu, substeps, y, work)
            # Element loops, not slice assignment: numba compiles a shape-mismatch error path (string
            # formatting, seconds of compile time) for every array-to-slice assignment.
            for i in range(6):
                x_bar[a + i] = y[i]
                for j in range(6):
                    Phi[a + i, a + j] = y[6 + 6 * i + j]
        elif block_kind[b] == BLOCK_CLOCK:
            for i in range(size):  # Phi_ij = dt^(j-i) / (j-i)!
                Phi[a + i, a + i] = 1.0
                term = 1.0
                for j in range(i + 1, size):
                    term *= dt_tu / (j - i)
                    Phi[a + i, a + j] = term
            for i in range(size):
                acc = 0.0
                for j in range(size):
                    acc += Phi[a + i, a + j] * x_hat[a + j]
                x_bar[a + i] = acc
        elif block_kind[b] == BLOCK_EMPIRICAL:
            _empirical_update(x_hat, x_bar, Phi, a, block_parameter[b], dt_tu, empirical_tau_tu)
        else:
            for i in range(size):
                x_bar[a + i] = x_hat[a + i]  # constant parameters
            if block_kind[b] == BLOCK_PARAMETER:
                Phi[a, a] = 1.0  # its row of the coupled transition (ekf.predict_covariance_into reads it)


@njit(cache=True)  # a call, not inlined: compiled once, not into every time_update (it runs only with DMC blocks)
def _empirical_update(x_hat, x_bar, Phi, a, s, dt_tu, tau_tu):
    """The Gauss-Markov acceleration w = x_hat[a : a + 3] of the spacecraft block at s over one step
    (estimation.process_noise.gauss_markov_gains): w <- m w, and the spacecraft's propagated
    position and velocity get the kinematic gains times w; the same numbers into Phi (its diagonal m and the
    coupling columns the covariance step reads, ekf._couple_parameters)."""
    decay, gain_r, gain_v = gauss_markov_gains(tau_tu, dt_tu)
    for i in range(3):
        w = x_hat[a + i]
        x_bar[a + i] = decay * w
        x_bar[s + i] += gain_r * w
        x_bar[s + 3 + i] += gain_v * w
        Phi[a + i, a + i] = decay
        Phi[s + i, a + i] = gain_r
        Phi[s + 3 + i, a + i] = gain_v


@njit(cache=True, inline="always")
def gated(innovation, S, gate_sigma, gate_after, accepted):
    """The residual gate: True (reject the measurement) when the pre-fit innovation lies beyond gate_sigma
    standard deviations of its own predicted spread, |y - H dx| > gate_sigma sqrt(H P H^T + R), once the
    filter has accepted gate_after measurements. The spread includes the state's uncertainty H P H^T, so the
    gate widens by itself while the filter is uncertain (a consistent filter rejects a fraction
    2 (1 - Phi(gate_sigma)) of clean data: 5.7e-7 at 5 sigma). gate_sigma = 0: no gate. The rule of Orekit's
    DynamicOutlierFilter for its Kalman filter (a warm-up of processed measurements, then k times
    sqrt(diag(H P H^T + R))); nyx's ResidRejectCrit is the same k-sigma pre-fit test (num_sigmas, with a
    min_accepted count in its earlier versions)."""
    return gate_sigma > 0.0 and accepted >= gate_after and abs(innovation) > gate_sigma * np.sqrt(S)


@njit(cache=True, inline="always")
def _store_prediction(states, matrices, k, x_bar, P_bar, Phi, block_kind, block_start, block_size):
    """Keep epoch k's x_bar, P_bar and the transition from k-1 (identity on constant blocks, whose Phi the
    covariance step never reads) for the smoother."""
    n = x_bar.shape[0]
    for i in range(n):
        states[k, 1, i] = x_bar[i]
        for j in range(n):
            matrices[k, 0, i, j] = P_bar[i, j]
            matrices[k, 2, i, j] = Phi[i, j]
    for b in range(block_kind.shape[0]):
        if block_kind[b] == BLOCK_CONSTANT:
            a = block_start[b]
            for i in range(block_size[b]):
                matrices[k, 2, a + i, a + i] = 1.0


@njit(cache=True, inline="always")
def _store_update(states, matrices, k, x_hat, P):
    n = x_hat.shape[0]
    for i in range(n):
        states[k, 0, i] = x_hat[i]
        for j in range(n):
            matrices[k, 1, i, j] = P[i, j]


@njit(cache=True, inline="always")
def covariance_health(x_hat, P):
    """STATUS_NONFINITE if x_hat (n,) or diag P (n, n) has a non-finite entry, else
    STATUS_COVARIANCE_NOT_POSITIVE if a variance is not positive, else STATUS_OK."""
    n = x_hat.shape[0]
    finite = True
    for i in range(n):
        if not (np.isfinite(x_hat[i]) and np.isfinite(P[i, i])):
            finite = False
    if not finite:
        return STATUS_NONFINITE
    for i in range(n):
        if P[i, i] <= 0.0:
            return STATUS_COVARIANCE_NOT_POSITIVE
    return STATUS_OK


@njit(cache=True, inline="always")
def record_epoch(k, x_hat, truth, P, n_nees, e, err, sig, nees, work_nees, z_nees):
    """Epoch k's row of the run's record: err = x_hat - x_true into e (n,) and err (m, n), sigma = sqrt(diag P)
    into sig (m, n), and the NEES of the first n_nees states into nees (m,) (nees_into; work_nees
    (n_nees, n_nees) and z_nees (n_nees,) its scratch)."""
    n = x_hat.shape[0]
    for i in range(n):  # element loops: see time_update
        e[i] = x_hat[i] - truth[k, i]
        err[k, i] = e[i]
    for i in range(n):
        sig[k, i] = np.sqrt(P[i, i])
    nees[k] = nees_into(e[:n_nees], P[:n_nees, :n_nees], work_nees, z_nees)


@njit(cache=True)  # a call, not inlined: it runs at one epoch in stride and kept out of the loop's body
def record_directions(k, e, P, truth, nees_k, chol, z, directions, work6, z6, u, v):
    """Epoch k's consistency resolved by direction (directions: kernel_args.DirectionRecord; arrays of length 0
    record nothing), after record_epoch: chol holds L with P = L L' and z = L^-1 e over the NEES's states (when
    nees_k is finite). Each spacecraft block's own 6-state NEES into nees_spacecraft[k, s] (nees_into; work6
    (6, 6), z6 (6,) its scratch). For a direction u, with v = L^-1 u: the NEES's component along u,
    (v'z)^2 / v'v, and the error along u in its own sigma, v'z / |v| (its mean is the bias in sigma), from
    [v'z, v'v]: into time_shift[k] for the common time shift, u = the true spacecraft states' central
    difference over one step (zero on other blocks; an estimate that lags the truth by d steps has e = -d u,
    and -v'z / v'v estimates d); into along_pair[k, p] for each pair's line of sight, u = +rho_hat on the
    second block's position and -rho_hat on the first's. Each spacecraft's position and velocity covariance
    blocks (6 numbers each: xx, yy, zz, xy, xz, yz) into covariance[k, s] (analysis.ric.ric_columns
    turns them into radial / in-track / cross-track sigmas). Only every stride-th epoch is recorded
    (kernel_args.MAX_DIRECTION_SAMPLES). u, v (n,) are scratch."""
    starts, pair_starts, stride = directions.spacecraft_starts, directions.pair_starts, directions.stride
    nees_spacecraft, time_shift = directions.nees_spacecraft, directions.time_shift
    along_pair, covariance = directions.along_pair, directions.covariance
    if nees_spacecraft.shape[0] == 0 or k % stride != 0:
        return
    m, n = truth.shape
    for s in range(starts.shape[0]):
        a = starts[s]
        nees_spacecraft[k, s] = nees_into(e[a : a + 6], P[a : a + 6, a : a + 6], work6, z6)
        for half in range(2):  # the position and velocity 3 x 3 blocks: xx, yy, zz, xy, xz, yz
            b = a + 3 * half
            covariance[k, s, 6 * half + 0] = P[b, b]
            covariance[k, s, 6 * half + 1] = P[b + 1, b + 1]
            covariance[k, s, 6 * half + 2] = P[b + 2, b + 2]
            covariance[k, s, 6 * half + 3] = P[b, b + 1]
            covariance[k, s, 6 * half + 4] = P[b, b + 2]
            covariance[k, s, 6 * half + 5] = P[b + 1, b + 2]
    if not np.isfinite(nees_k):
        return
    lo, hi = max(k - 1, 0), min(k + 1, m - 1)
    for i in range(n):
        u[i] = 0.0
    if hi > lo:
        for s in range(starts.shape[0]):
            for i in range(starts[s], starts[s] + 6):
                u[i] = (truth[hi, i] - truth[lo, i]) / (hi - lo)
    time_shift[k, 0], time_shift[k, 1] = _whitened_along(u, chol, z, v)
    for p in range(pair_starts.shape[0]):
        a, b = pair_starts[p, 0], pair_starts[p, 1]
        for i in range(n):
            u[i] = 0.0
        distance = 0.0
        for i in range(3):
            u[b + i] = truth[k, b + i] - truth[k, a + i]
            distance += u[b + i] * u[b + i]
        distance = np.sqrt(distance)
        for i in range(3):
            u[b + i] /= distance
            u[a + i] = -u[b + i]
        along_pair[k, p, 0], along_pair[k, p, 1] = _whitened_along(u, chol, z, v)


@njit(cache=True, inline="always")
def _whitened_along(u, chol, z, v):
    """(v'z, v'v) with v = L^-1 u solved by forward substitution over L's rows (chol (r, r), z (r,), u, v (>= r,))."""
    r = z.shape[0]
    projected, length = 0.0, 0.0
    for i in range(r):
        s = u[i]
        for j in range(i):
            s -= chol[i, j] * v[j]
        v[i] = s / chol[i, i]
        projected += v[i] * z[i]
        length += v[i] * v[i]
    return projected, length


@njit(cache=True, inline="always")
def position_beyond_bound(e, layout, divergence_position_lu):
    """True if a spacecraft block's position error |e[a : a + 3]| (e (n,)) exceeds divergence_position_lu."""
    block_kind, block_start = layout.kind, layout.start
    for b in range(block_kind.shape[0]):
        if block_kind[b] == BLOCK_SPACECRAFT:
            a = block_start[b]
            if np.sqrt(e[a] ** 2 + e[a + 1] ** 2 + e[a + 2] ** 2) > divergence_position_lu:
                return True
    return False


@njit(cache=True, inline="always")
def scratch_buffers(n, n_nees):
    """The loop's scratch (kernel_args.Buffers), allocated once per run (in the loop, allocation had cost as much
    as the arithmetic)."""
    return Buffers(np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.zeros(n), np.empty(n), np.empty(n),
                   np.empty((n, n)), np.zeros((n, n)), np.empty(6), np.empty(6), np.empty(6), np.empty(PROPAGATION_SIZE),
                   np.empty((5, STM_SIZE)), np.empty((6, 6)), np.empty((n_nees, n_nees)), np.empty(n_nees),
                   np.empty((6, 6)), np.empty(6), np.empty(n), np.empty(n))


@njit(cache=True, inline="always")
def record_row(k, x_hat, truth, P, n_nees, err, sig, nees, directions, buf):
    """Epoch k's row of the run's record (record_epoch) and, at the direction record's sampled epochs (every
    stride-th; length 0: none), its directions (record_directions, called only there); buf: the loop's
    scratch (kernel_args.Buffers)."""
    record_epoch(k, x_hat, truth, P, n_nees, buf.e, err, sig, nees, buf.work_nees, buf.z_nees)
    if directions.nees_spacecraft.shape[0] > 0 and k % directions.stride == 0:
        record_directions(k, buf.e, P, truth, nees[k], buf.work_nees, buf.z_nees, directions, buf.work6, buf.z6,
                          buf.u, buf.v)


@njit(cache=True, inline="always")
def run_outputs(m, n, n_channels):
    """err, sig (m, n), nees (m,), innovations, innov_std (m, C) all NaN, and rejected (m, C) all False."""
    return (np.full((m, n), np.nan), np.full((m, n), np.nan), np.full(m, np.nan), np.full((m, n_channels), np.nan),
            np.full((m, n_channels), np.nan), np.zeros((m, n_channels), dtype=np.bool_))


@njit(cache=True)
def run_ekf(model, x0_hat, P0, noise, truth, y_obs, known_states, channels, layout, dynamics, settings, burns,
            record, directions, calls):
    """Run one EKF pass. model: the dynamics model code, read at run time (one compiled body for every scenario).
    x0_hat (n,); P0 (n, n); noise: the process noise added at every step (Eq. 12; kernel_args.ProcessNoise,
    step_process_noise); truth (m, n) at the epochs t_k = t0_tu + k dt_tu; y_obs (m, C) (row 0 unused, NaN: none);
    known_states (m, K, 6); burns (N, 3) (apply_burns); the named groups as estimation.kernel_args describes them
    (calls: the time update, measurement row and covariance prediction by address, shared_calls). Returns (err,
    sigma (m, n), nees (m,), innovation, innovation_std, rejected (m, C), status, fail_step): after each epoch's
    update, the innovations pre-fit (rejected ones too); rows after a failure stay NaN."""
    block_kind, block_start, block_size = layout.kind, layout.start, layout.size
    dt_tu, t0_tu = dynamics.dt_tu, dynamics.t0_tu
    n_gain, n_nees, divergence_position_lu = settings.n_gain, settings.n_nees, settings.divergence_position_lu
    underweight, gate_sigma, gate_after = settings.underweight, settings.gate_sigma, settings.gate_after
    store_states, store_matrices = record.states, record.matrices
    channel_kind, sigma = channels.kind, channels.sigma
    (m, n), n_channels = truth.shape, sigma.shape[0]
    err, sig, nees, innovations, innov_std, rejected = run_outputs(m, n, n_channels)
    accepted = 0  # measurements the filter has updated with, all channels (the gate's warm-up count)
    x_hat, P = x0_hat.copy(), P0.copy()  # P and P_spare swap roles at each covariance step (none in place)
    buf = scratch_buffers(n, n_nees)
    x_bar, e, H, h, K, Phi = buf.x_bar, buf.e, buf.H, buf.h, buf.K, buf.Phi
    dx, dx_spare, P_spare = buf.dx, buf.dx_spare, buf.P_spare  # they swap roles with dx and P: locals
    direction_stride = directions.stride if directions.nees_spacecraft.shape[0] > 0 else 0
    Q_work, ric_axes = np.empty((n, n)), np.empty((3, 3))  # step_process_noise's, used with RIC noise only
    ric_steps = noise.primaries.shape[0]
    first = np.int64(0)  # not the literal 0: record_directions would compile a second time for it
    record_row(first, x_hat, truth, P, n_nees, err, sig, nees, directions, buf)
    storing = store_states.shape[0] > 0
    if storing:
        _store_update(store_states, store_matrices, 0, x_hat, P)

    for k in range(1, m):
        apply_burns(x_hat, P, burns, k - 1)  # a manoeuvre after the last epoch: its estimated Delta-v
        # Time update: reference trajectory and STM from the last estimate (Eq. 10-12).
        calls.time_update(x_hat, x_bar, Phi, layout, model, dynamics, t0_tu + (k - 1) * dt_tu, buf.y_stm,
                          buf.work_stm)
        Q = noise.Q if ric_steps == 0 else step_process_noise(noise, Q_work, x_hat, k - 1, block_kind, block_start,
                                                             ric_axes)
        P, P_spare = calls.predict_covariance(P, Phi, Q, P_spare, buf.work_block, block_kind, block_start,
                                              block_size), P
        if storing:
            _store_prediction(store_states, store_matrices, k, x_bar, P, Phi, block_kind, block_start, block_size)
        # Measurement update, one scalar channel at a time, all linearised at x_bar (Eq. 13, 17, 20-24), not in
        # place (the spares take the names).
        for i in range(n):
            dx[i] = 0.0
        for c in range(n_channels):
            y_meas = y_obs[k, c]
            if not np.isfinite(y_meas):
                continue
            predicted = calls.measurement_row(channels, c, x_bar, known_states[k], H, buf.g_receiver,
                                              buf.g_transmitter, buf.g_second)[0]
            y = residual(channel_kind[c], y_meas, predicted)
            R = sigma[c] ** 2
            innovation, S = prefit_into(dx, P, y, H, R, h)
            if not np.isfinite(innovation):  # a run with a non-finite innovation is never "ok"
                return err, sig, nees, innovations, innov_std, rejected, STATUS_NONFINITE, k
            innovations[k, c] = innovation
            innov_std[k, c] = np.sqrt(S) if S > 0.0 else np.nan
            if gated(innovation, S, gate_sigma, gate_after, accepted):
                rejected[k, c] = True  # edited: no update, dx and P stay as they are
                continue
            apply_update_into(dx, P, innovation, S, R, n_gain, underweight, dx_spare, P_spare, h, K)
            dx, dx_spare = dx_spare, dx
            P, P_spare = P_spare, P
            accepted += 1
        for i in range(n):
            x_hat[i] = x_bar[i] + dx[i]
        if storing:
            _store_update(store_states, store_matrices, k, x_hat, P)
        status = covariance_health(x_hat, P)  # a diverged run stops here and reports why
        if status == STATUS_OK:
            record_epoch(k, x_hat, truth, P, n_nees, e, err, sig, nees, buf.work_nees, buf.z_nees)
            if direction_stride and k % direction_stride == 0:  # the call only where it records
                record_directions(k, e, P, truth, nees[k], buf.work_nees, buf.z_nees, directions, buf.work6, buf.z6,
                                  buf.u, buf.v)
            status = STATUS_ERROR_BEYOND_BOUND if position_beyond_bound(e, layout, divergence_position_lu) else status
        if status != STATUS_OK:
            return err, sig, nees, innovations, innov_std, rejected, status, k
    return err, sig, nees, innovations, innov_std, rejected, STATUS_OK, -1
