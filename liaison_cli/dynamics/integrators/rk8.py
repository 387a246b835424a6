"""Fixed-step 8th-order Runge-Kutta (the 12-stage Dormand-Prince 8(5,3) formula that scipy's DOP853 uses,
without its error control): the stage kernels every RK8 here shares (`rk8_stage_input`, `rk8_combine`), the
CRTBP's state and STM (`rk8_advance` in place, `rk8_state`, `rk8_state_stm`), the CRTBP truth with the lunar
harmonics (`rk8_states_forced`), the dated ephemeris field's
(`rk8_advance_ephemeris`), and the step count per interval (`step_counts`) chosen by a Sundman-type rule: the
step never exceeds STEP_FRACTION of the local Kepler time sqrt(r^3 / GM) about the nearer primary. Near the
Moon at the perilune of an NRHO (r ~ 3,200 km) that is ~40 s; at apolune (70,000 km) ~1 h. The rule needs no
adaptive integrator per run: the batch estimator and every Monte Carlo run of a scenario reuse one schedule
computed on the nominal trajectory. Accuracy against DOP853 at rtol 1e-13 is tested in
tests/unit/estimation/test_batch.py.
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.crtbp_field import field_derivative_into, field_scratch, field_state_stm_rhs
from liaison_cli.dynamics.ephemeris_dynamics import STM_SIZE, ephemeris_derivative
from liaison_cli.dynamics.integrators import dop853_tableau as _dop853
from liaison_cli.dynamics.integrators.rk4 import steps_between

# The tableau is vendored as literal floats (tools/vendor_dop853_tableau.py copied it from scipy's private
# dop853_coefficients module): reading that file at import tied every command to a scipy internal, and
# importing it as a module would load scipy.integrate (~0.25 s at every start).
RK8_A = np.ascontiguousarray(_dop853.A, dtype=np.float64)
RK8_B = np.ascontiguousarray(_dop853.B, dtype=np.float64)
RK8_C = np.ascontiguousarray(_dop853.C, dtype=np.float64)
# Read-only, as numba sees a global array: one compiled signature whether a caller is compiled or Python.
for _table in (RK8_A, RK8_B, RK8_C):
    _table.setflags(write=False)
STEP_FRACTION = 0.08


@njit(cache=True, inline="always")
def rk8_stage_input(y, h, a, k, s, tmp):
    """tmp = y + h sum_j a[s, j] k[j]: the input of stage s (every RK8 integrator here shares it)."""
    for i in range(y.shape[0]):
        acc = y[i]
        for j in range(s):
            acc += h * a[s, j] * k[j, i]
        tmp[i] = acc


@njit(cache=True, inline="always")
def rk8_combine(y, h, b, k):
    """y += h sum_s b[s] k[s]: the step's update."""
    for i in range(y.shape[0]):
        acc = 0.0
        for s in range(12):
            acc += b[s] * k[s, i]
        y[i] += h * acc


@njit(cache=True)
def _rk8_step(y, h, params, a, b, k, tmp, scratch):
    """One RK8 step in place of a 6-state, or of the 42-vector [state, Phi]; k (12, len(y)), tmp scratch, and
    scratch the added terms' (crtbp_field.field_scratch)."""
    for s in range(12):
        rk8_stage_input(y, h, a, k, s, tmp)
        if y.shape[0] == 6:
            field_derivative_into(tmp, params, k[s], scratch)
        else:
            field_state_stm_rhs(tmp, params, k[s], scratch)
    rk8_combine(y, h, b, k)


@njit(cache=True)
def rk8_advance(y, dt_tu, n_steps, params, k, tmp):
    """Advance y in place over dt_tu in n_steps RK8 steps: y (6,) a state, or y (42,) [state, Phi row-major]
    carried on from earlier intervals, so Phi stays Phi(t, t0). k (12, len(y)), tmp (len(y),) scratch."""
    h = dt_tu / n_steps
    scratch = field_scratch(params, tmp)
    for _ in range(n_steps):
        _rk8_step(y, h, params, RK8_A, RK8_B, k, tmp, scratch)


@njit(cache=True)
def rk8_state(state, dt_tu, n_steps, params):
    """(6,) state -> (6,) state after dt_tu in n_steps equal RK8 steps."""
    y = state.copy()
    k = np.empty((12, 6))
    tmp = np.empty(6)
    h = dt_tu / n_steps
    scratch = field_scratch(params, tmp)
    for _ in range(n_steps):
        _rk8_step(y, h, params, RK8_A, RK8_B, k, tmp, scratch)
    return y


@njit(cache=True)
def rk8_state_stm(state, dt_tu, n_steps, params):
    """(6,) state -> (state (6,), Phi (6, 6)) after dt_tu in n_steps equal RK8 steps."""
    y = np.zeros(42)
    for i in range(6):
        y[i] = state[i]
        y[6 + 7 * i] = 1.0
    k = np.empty((12, 42))
    tmp = np.empty(42)
    h = dt_tu / n_steps
    scratch = field_scratch(params, tmp)
    for _ in range(n_steps):
        _rk8_step(y, h, params, RK8_A, RK8_B, k, tmp, scratch)
    phi = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            phi[i, j] = y[6 + 6 * i + j]
    return y[0:6].copy(), phi


@njit(cache=True)
def rk8_states_forced(state0, times_tu, max_step_tu, params, acceleration_lu_tu2):
    """The CRTBP truth by RK8 (integrators.rk4.rk4_states_forced's contract): one trajectory (6,) -> (m, 6) sampled
    at times_tu by steps of at most max_step_tu, with an extra acceleration (m, 3) given at the samples and linear
    between them, read at each stage's time. For a field that is costly to evaluate (the lunar harmonics): an
    eighth-order step can be tens of times longer than RK4's for the same error."""
    m = times_tu.shape[0]
    out = np.empty((m, 6))
    y = state0.copy()
    for i in range(6):
        out[0, i] = y[i]
    k = np.empty((12, 6))
    tmp = np.empty(6)
    scratch = field_scratch(params, tmp)
    for j in range(1, m):
        substeps, h = steps_between(times_tu, j, max_step_tu)
        for s in range(substeps):
            for stage in range(12):
                rk8_stage_input(y, h, RK8_A, k, stage, tmp)
                field_derivative_into(tmp, params, k[stage], scratch)
                fraction = (s + RK8_C[stage]) / substeps
                for i in range(3):
                    a0 = acceleration_lu_tu2[j - 1, i]
                    k[stage, 3 + i] += a0 + (acceleration_lu_tu2[j, i] - a0) * fraction
            rk8_combine(y, h, RK8_B, k)
        for i in range(6):
            out[j, i] = y[i]
    return out


@njit(cache=True)
def rk8_advance_ephemeris(y, t_s, dt_s, n_steps, coeffs, start_s, interval_s, n_records, bodies, gms, gm_earth,
                          cr_am, terms, a, b, c):
    """Advance y (6,), (42,) or (48,) (the layouts of dynamics.ephemeris_dynamics.ephemeris_derivative) in place
    from t_s over dt_s in n_steps RK8 steps (tableau a, b, c)."""
    size = y.shape[0]
    with_stm = size >= STM_SIZE
    k = np.empty((12, size))
    tmp = np.empty(size)
    h = dt_s / n_steps
    t = t_s
    for _ in range(n_steps):
        for s in range(12):
            rk8_stage_input(y, h, a, k, s, tmp)
            ephemeris_derivative(t + c[s] * h, tmp, coeffs, start_s, interval_s, n_records, bodies, gms, gm_earth,
                                 cr_am, terms, with_stm, k[s])
        rk8_combine(y, h, b, k)
        t += h


def kepler_time_tu(positions_lu, mu: float) -> np.ndarray:
    """sqrt(r^3 / GM) about the nearer primary (by that time), (m, 3) -> (m,) in TU."""
    r_earth = np.linalg.norm(positions_lu - np.array([-mu, 0.0, 0.0]), axis=1)
    r_moon = np.linalg.norm(positions_lu - np.array([1.0 - mu, 0.0, 0.0]), axis=1)
    return np.minimum(np.sqrt(r_earth**3 / (1.0 - mu)), np.sqrt(r_moon**3 / mu))


def step_counts(positions_lu, dt_tu: float, mu: float, step_fraction: float = STEP_FRACTION) -> np.ndarray:
    """Steps per interval (m - 1,) for sampled positions (m, k, 3) of every spacecraft: each interval's step
    is at most step_fraction of the smallest Kepler time at its two ends, halved once more for the dip
    between samples."""
    positions_lu = np.asarray(positions_lu, dtype=float)
    m = positions_lu.shape[0]
    t_kepler = np.min(np.stack([kepler_time_tu(positions_lu[:, s], mu) for s in range(positions_lu.shape[1])]),
                      axis=0)
    shortest = np.minimum(t_kepler[:-1], t_kepler[1:])
    counts = np.ceil(dt_tu / (0.5 * step_fraction * shortest)).astype(np.int64)
    return np.maximum(counts, 1) if m > 1 else np.zeros(0, dtype=np.int64)

