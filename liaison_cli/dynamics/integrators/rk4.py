"""Fixed-step classical RK4 for the CRTBP (dynamics.crtbp's right-hand sides, inlined).

The filter's state + STM over one measurement interval, the STM on a coarser grid than the state
(`rk4_state_stm_into`, no allocation for point masses, one scratch per call with added terms; `rk4_state_stm`
allocates its result), the state + STM with every step (`rk4_variational_into`, `rk4_variational`), and the
compiled truth: one trajectory sampled at given times by steps of at most max_step_tu (`rk4_states_forced`, with
an unmodelled acceleration; `rk4_states` calls it with none). All numba-compiled and cached on disk but
`rk4_states`, a Python call of the compiled one.
"""

import numpy as np
from numba import njit

from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.constants import TU_S
from liaison_cli.dynamics.crtbp_field import (field_derivative_into, field_scratch, field_state_stm_rhs,
                                              field_truth_derivative_into)


@njit(cache=True)
def rk4_state_stm(state, dt_tu, substeps, params):
    """Propagate one state (6,) and its STM over dt_tu: (state_end (6,), phi (6, 6)) with
    phi = Phi(t + dt, t), as the filter does (rk4_state_stm_into: the state by `substeps` RK4 steps, the STM
    by fewer, as extra equations alongside a coarser state, so the linearisation follows the trajectory)."""
    y = np.empty(42)
    rk4_state_stm_into(state, dt_tu, substeps, params, y, np.empty((5, 42)))
    return y[0:6].copy(), y[6:].copy().reshape(6, 6)


@njit(cache=True)
def rk4_variational(state, dt_tu, steps, params):
    """(state_end (6,), phi (6, 6)) by `steps` RK4 steps of the 42 state + STM equations together: every step
    on the STM too (a reference for the coarse STM, and the scheme of the filter before it)."""
    y = np.empty(42)
    rk4_variational_into(state, dt_tu, steps, params, y, np.empty((5, 42)))
    return y[0:6].copy(), y[6:].copy().reshape(6, 6)


STM_STEP_RATIO = 4  # the STM takes one RK4 step per STM_STEP_RATIO of the state's (rk4_state_stm_into) ...
STM_MAX_STEP_TU = 200.0 / TU_S  # ... and none longer than 200 s, whatever the interval


@njit(cache=True, inline="always")
def stm_steps(dt_tu, substeps):
    """The STM's RK4 steps over an interval: a quarter of the state's substeps (at least one), more when a
    step would exceed STM_MAX_STEP_TU, never more than the state's."""
    coarse = max(substeps // STM_STEP_RATIO, int(np.ceil(abs(dt_tu) / STM_MAX_STEP_TU - 1e-9)), 1)
    return min(coarse, substeps)


@njit(cache=True, inline="always")
def rk4_state_stm_into(state, dt_tu, substeps, params, y, work):
    """rk4_state_stm without allocation: y (42,) <- [state_end (6), Phi(t + dt, t) row-major (36)];
    work (5, 42) scratch (the filter calls this for every spacecraft at every epoch: no allocation for point masses;
    with added terms, their scratch once per call, crtbp_field.field_scratch). `state`
    must not share memory with y or work: it is read again after they are written.

    The STM on a coarser grid than the state: the state by `substeps` RK4 steps of its own 6 equations (bit
    for bit the state of `substeps` steps of the 42 state + STM equations), Phi by stm_steps(dt, substeps)
    steps of the 42 equations (a quarter of the substeps, steps of at most 200 s), whose coarser state only
    places the Jacobian along the way. At 187.5 s and 4 substeps: 16 + 4 evaluations per interval instead of
    16 of the 42 equations; the state's 6 cost about a third of them. There Phi is within 5e-8 of DOP853 at
    rtol 1e-13 (relative to its largest entry; 2e-10 with every substep) for eml2_lunar's lunar orbiter,
    within 1e-6 near c5_star_eml2_nrho's NRHO perilune and 2.7e-6 near the Gateway NRHO's 3,250 km one (the
    fastest a shipped scenario flies), far inside what the EKF already accepts: it takes Phi at its
    estimate, and a 1-sigma move of the state (300 m; 20 m for the lunar orbiter) changes Phi at least 57
    times (NRHO: 190 times) more than the coarse step does, interval by interval (benchmarks/bare_loop.py
    --accuracy). The 200 s bound keeps longer intervals there: without it the orbiter's Phi was 5e-6 off at
    600 s and 4e-5 at 1,000 s."""
    scratch = field_scratch(params, y)  # the added terms' scratch, once per interval (none for point masses)
    _variational_steps(state, dt_tu, stm_steps(dt_tu, substeps), params, y, work, scratch)
    _state_steps(state, dt_tu, substeps, params, y, work, scratch)


@njit(cache=True, inline="always")
def rk4_variational_into(state, dt_tu, steps, params, y, work):
    """y (42,) <- `steps` RK4 steps of the 42 state + STM (variational) equations from [state, identity]
    (work (5, 42) scratch): the STM's half of rk4_state_stm_into, and with every substep the scheme it
    replaced (benchmarks/bare_loop.py's yardstick)."""
    _variational_steps(state, dt_tu, steps, params, y, work, field_scratch(params, y))


@njit(cache=True, inline="always")
def _variational_steps(state, dt_tu, steps, params, y, work, scratch):
    """rk4_variational_into with the added terms' scratch (crtbp_field.field_scratch) of the caller."""
    h = dt_tu / steps
    k1, k2, k3, k4, tmp = work[0], work[1], work[2], work[3], work[4]
    for i in range(6):
        y[i] = state[i]
    for i in range(6, 42):
        y[i] = 0.0
    for i in range(6):
        y[6 + 7 * i] = 1.0
    for _ in range(steps):
        field_state_stm_rhs(y, params, k1, scratch)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * h * k1[i]
        field_state_stm_rhs(tmp, params, k2, scratch)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * h * k2[i]
        field_state_stm_rhs(tmp, params, k3, scratch)
        for i in range(42):
            tmp[i] = y[i] + h * k3[i]
        field_state_stm_rhs(tmp, params, k4, scratch)
        for i in range(42):
            y[i] += (h / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True, inline="always")
def _state_steps(state, dt_tu, steps, params, y, work, scratch):
    """y[0:6] <- `steps` RK4 steps of the state alone from `state`; work's rows are scratch, and scratch the added
    terms' (crtbp_field.field_scratch)."""
    h = dt_tu / steps
    s, mid = work[0, 0:6], work[0, 6:12]
    k1, k2, k3, k4 = work[1, 0:6], work[1, 6:12], work[1, 12:18], work[1, 18:24]
    for i in range(6):
        s[i] = state[i]
    for _ in range(steps):
        field_derivative_into(s, params, k1, scratch)
        for i in range(6):
            mid[i] = s[i] + 0.5 * h * k1[i]
        field_derivative_into(mid, params, k2, scratch)
        for i in range(6):
            mid[i] = s[i] + 0.5 * h * k2[i]
        field_derivative_into(mid, params, k3, scratch)
        for i in range(6):
            mid[i] = s[i] + h * k3[i]
        field_derivative_into(mid, params, k4, scratch)
        for i in range(6):
            s[i] += (h / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    for i in range(6):
        y[i] = s[i]


def rk4_states(state0, times_tu, max_step_tu, params):
    """Sample one trajectory (6,) -> (m, 6) at times_tu (times_tu[0] = epoch of state0) by fixed RK4 steps
    of at most max_step_tu between consecutive samples: rk4_states_forced with no extra force, the compiled
    truth propagator (no Python in the loop, no scipy import). Called from Python, not compiled itself: as a
    compiled function of its own it was 2 s of a dated scenario's first run (numba compiled its allocation and
    linked the propagator in again), for the same numbers to the last bit."""
    times_tu = np.ascontiguousarray(times_tu, dtype=float)
    return rk4_states_forced(writable_c(state0), times_tu, float(max_step_tu), writable_c(params),
                             np.zeros((times_tu.shape[0], 3)))


@njit(cache=True)
def rk4_states_forced(state0, times_tu, max_step_tu, params, acceleration_lu_tu2):
    """rk4_states with an extra acceleration on the rotating axes, LU/TU^2, given at the samples (m, 3) and
    linear between them: the truth's unmodelled force (scenario model_error: a constant, or a Gauss-Markov
    process drawn per run). A constant table adds its row exactly (a + 0 f is a); zeros add nothing."""
    m = times_tu.shape[0]
    out = np.empty((m, 6))
    y = state0.copy()
    for i in range(6):
        out[0, i] = y[i]
    tmp = np.empty(6)
    k1, k2, k3, k4 = np.empty(6), np.empty(6), np.empty(6), np.empty(6)  # no allocation per stage (12 % faster)
    scratch = field_scratch(params, tmp)
    for j in range(1, m):
        substeps, h = steps_between(times_tu, j, max_step_tu)
        for s in range(substeps):
            start, middle, end = s / substeps, (s + 0.5) / substeps, (s + 1.0) / substeps
            field_truth_derivative_into(y, params, k1, scratch)
            _forced(k1, acceleration_lu_tu2, j, start)
            for i in range(6):
                tmp[i] = y[i] + 0.5 * h * k1[i]
            field_truth_derivative_into(tmp, params, k2, scratch)
            _forced(k2, acceleration_lu_tu2, j, middle)
            for i in range(6):
                tmp[i] = y[i] + 0.5 * h * k2[i]
            field_truth_derivative_into(tmp, params, k3, scratch)
            _forced(k3, acceleration_lu_tu2, j, middle)
            for i in range(6):
                tmp[i] = y[i] + h * k3[i]
            field_truth_derivative_into(tmp, params, k4, scratch)
            _forced(k4, acceleration_lu_tu2, j, end)
            for i in range(6):
                y[i] += (h / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        for i in range(6):  # element loops compile faster than slice assignment (no shape-error path)
            out[j, i] = y[i]
    return out


@njit(cache=True, inline="always")
def steps_between(times_tu, j, max_step_tu):
    """(substeps, h): the fewest equal steps of at most max_step_tu from sample j - 1 to sample j (the truth's)."""
    span = times_tu[j] - times_tu[j - 1]
    substeps = max(1, int(np.ceil(abs(span) / max_step_tu - 1e-9)))
    return substeps, span / substeps


@njit(cache=True, inline="always")
def _forced(rate, acceleration, j, fraction):
    """rate plus the acceleration (m, 3) at that fraction of the interval from sample j - 1 to j, linear
    between them (element by element: an array difference compiled numpy's broadcasting, 3 s of a first run)."""
    for i in range(3):
        a0 = acceleration[j - 1, i]
        rate[3 + i] += a0 + (acceleration[j, i] - a0) * fraction
    return rate

