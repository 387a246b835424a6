"""Fixed-step classical RK4 for the CRTBP (dynamics.crtbp's right-hand sides, inlined).

The filter's state + STM over one measurement interval (`rk4_state_stm_into`, no allocation; `rk4_state_stm`
allocates its result), and the compiled truth: one trajectory sampled at given times by steps of at most
max_step_tu (`rk4_states`; `rk4_states_forced` with a constant unmodelled acceleration). All numba-compiled
and cached on disk.
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.crtbp import derivative, state_stm_rhs


@njit(cache=True)
def rk4_state_stm(state, dt_tu, substeps, mu):
    """Propagate one state (6,) and its STM over dt_tu with `substeps` fixed RK4 steps.

    Returns (state_end (6,), phi (6, 6)) with phi = Phi(t + dt, t). The STM is integrated as extra
    equations alongside the state, so the linearisation follows the propagated trajectory.
    """
    y = np.empty(42)
    rk4_state_stm_into(state, dt_tu, substeps, mu, y, np.empty((5, 42)))
    return y[0:6].copy(), y[6:].copy().reshape(6, 6)


@njit(cache=True, inline="always")
def rk4_state_stm_into(state, dt_tu, substeps, mu, y, work):
    """rk4_state_stm without allocation: y (42,) <- [state_end (6), Phi(t + dt, t) row-major (36)];
    work (5, 42) scratch. The filter calls this twice per epoch and spacecraft, so seven small
    allocations per call were a third of a 10-day run's time."""
    h = dt_tu / substeps
    k1, k2, k3, k4, tmp = work[0], work[1], work[2], work[3], work[4]
    for i in range(6):
        y[i] = state[i]
    for i in range(6, 42):
        y[i] = 0.0
    for i in range(6):
        y[6 + 7 * i] = 1.0
    for _ in range(substeps):
        state_stm_rhs(y, mu, k1)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * h * k1[i]
        state_stm_rhs(tmp, mu, k2)
        for i in range(42):
            tmp[i] = y[i] + 0.5 * h * k2[i]
        state_stm_rhs(tmp, mu, k3)
        for i in range(42):
            tmp[i] = y[i] + h * k3[i]
        state_stm_rhs(tmp, mu, k4)
        for i in range(42):
            y[i] += (h / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def rk4_states(state0, times_tu, max_step_tu, mu):
    """Sample one trajectory (6,) -> (m, 6) at times_tu (times_tu[0] = epoch of state0) by fixed RK4 steps
    of at most max_step_tu between consecutive samples (the compiled truth propagator: no Python in the
    loop, no scipy import)."""
    return rk4_states_forced(state0, times_tu, max_step_tu, mu, np.zeros(3))


@njit(cache=True)
def rk4_states_forced(state0, times_tu, max_step_tu, mu, acceleration_lu_tu2):
    """rk4_states with a constant extra acceleration (3,) on the rotating axes, LU/TU^2: the truth's
    unmodelled force (scenario model_error.truth_acceleration_m_s2). Zero adds nothing: x + 0.0 is x."""
    m = times_tu.shape[0]
    out = np.empty((m, 6))
    y = state0.copy()
    for i in range(6):
        out[0, i] = y[i]
    tmp = np.empty(6)
    for j in range(1, m):
        span = times_tu[j] - times_tu[j - 1]
        substeps = max(1, int(np.ceil(abs(span) / max_step_tu - 1e-9)))
        h = span / substeps
        for _ in range(substeps):
            k1 = _forced(derivative(y, mu), acceleration_lu_tu2)
            for i in range(6):
                tmp[i] = y[i] + 0.5 * h * k1[i]
            k2 = _forced(derivative(tmp, mu), acceleration_lu_tu2)
            for i in range(6):
                tmp[i] = y[i] + 0.5 * h * k2[i]
            k3 = _forced(derivative(tmp, mu), acceleration_lu_tu2)
            for i in range(6):
                tmp[i] = y[i] + h * k3[i]
            k4 = _forced(derivative(tmp, mu), acceleration_lu_tu2)
            for i in range(6):
                y[i] += (h / 6.0) * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        for i in range(6):  # element loops compile faster than slice assignment (no shape-error path)
            out[j, i] = y[i]
    return out


@njit(cache=True, inline="always")
def _forced(rate, acceleration):
    for i in range(3):
        rate[3 + i] += acceleration[i]
    return rate

