"""Adaptive DOP853 for the CRTBP, compiled: the same method, step-size control and dense output as scipy's
`solve_ivp(method="DOP853", t_eval=...)`, without Python in the loop.

The corrector (orbits.periodic), the orbit catalogue, the observability analysis and the orbit plots integrate
the CRTBP state, or its state and STM, at tolerances near the arithmetic's (rtol 1e-13); through scipy each
step cost twelve Python calls of the right-hand side and a dozen small numpy operations, about 30 ms per
propagation of the corrector. Here the whole integration is one compiled call (benchmarks in docs/performance.md).

What scipy 1.17's DOP853 does, and this does the same (Hairer, Norsett & Wanner, *Solving ODEs I*, II.4-II.6,
and the DOP853 code):
- the starting step: Hairer's estimate from f(t0, y0) and one Euler step (scipy's `select_initial_step`, order
  7), capped by the span;
- a step of the 12-stage tableau; the error norm from the 5th and 3rd order estimates, each weighted by
  atol + rtol max(|y|, |y_new|), combined as |h| |e5|^2 / sqrt((|e5|^2 + 0.01 |e3|^2) n);
- accepted below 1, the next step scaled by min(10, 0.9 err^(-1/8)) (at most 1 right after a rejection);
  rejected, the step scaled by max(0.2, 0.9 err^(-1/8)); the last step cut to end on the span's end;
- every asked time within a step (t_old, t] read from the 7th-order dense output (three extra stages).

Where it differs: the stage and error sums are added in a fixed order (scipy's are BLAS products, whose order
depends on the BLAS kernel), so the two agree to rounding, not bit for bit (tests/unit/dynamics/test_dop853.py
compares them step count for step count); samples at the start time are the start itself, and repeated
sample times are allowed (scipy refuses them); and the loop is bounded (MAX_STEPS) and stops on a step size
that is not finite, where scipy would go on for ever. A non-finite field inside a step is rejected and the step
shrunk, as scipy does, until it fails as too small; samples are returned as computed (a caller checks them, as
the corrector checks its residual).
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.crtbp import state_stm_rhs, truth_derivative_into
from liaison_cli.dynamics.integrators import dop853_tableau as _tableau
from liaison_cli.dynamics.integrators.rk8 import RK8_A as A
from liaison_cli.dynamics.integrators.rk8 import RK8_B as B

N_STAGES = 12
N_STAGES_EXTENDED = 16  # the step's 12, the derivative at its end, the dense output's 3
ERROR_EXPONENT = -1.0 / 8.0  # -1 / (error estimator order 7 + 1)
SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0

OK = 0
STEP_TOO_SMALL = 1
TOO_MANY_STEPS = 2
NOT_FINITE = 3
# A compiled loop cannot be interrupted (Ctrl-C waits for it), so it is bounded: a catalogue member's period with
# its STM at rtol 1e-13 takes under 1,000 steps, 30 days of a 100 km polar lunar orbit with its STM 27,482 (measured).
MAX_STEPS = 500_000

TRUTH_RTOL = 1e-12  # the reference propagations' default tolerances
TRUTH_ATOL = 1e-13


def _table(rows):
    table = np.ascontiguousarray(rows, dtype=np.float64)
    table.setflags(write=False)  # read-only, as numba sees a global array
    return table


# A step's stages (A, B) are the fixed-step RK8's tables; the stage times (C, C_EXTRA) are not needed: the CRTBP is
# autonomous.
E5 = _table(_tableau.E5)
E3 = _table(_tableau.E3)
A_EXTRA = _table(_tableau.A_EXTRA)
D = _table(_tableau.D)


@njit(cache=True)  # a call, not inlined at its five places: compiled once (seconds less on a cold cache)
def _rhs_into(y, mu, out):
    """The CRTBP's right-hand side of a state (6,) or of [state, Phi row-major] (42,): the arithmetic of
    crtbp.derivative and crtbp.state_stm_derivative, which scipy was given."""
    if y.shape[0] == 6:
        truth_derivative_into(y, mu, out)
    else:
        state_stm_rhs(y, mu, out)


@njit(cache=True, inline="always")
def _stage_input(y, h, a_row, k, s, out):
    """out = y + (sum_j<s a_row[j] k[j]) h, as scipy's rk_step forms a stage's input."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(s):
            acc += k[j, i] * a_row[j]
        out[i] = y[i] + acc * h


@njit(cache=True, inline="always")
def _norm_squared(values, n):
    """|values|^2 as scipy forms it: the Euclidean norm, squared (the square root, then its square)."""
    acc = 0.0
    for i in range(n):
        acc += values[i] * values[i]
    root = np.sqrt(acc)
    return root * root


@njit(cache=True)
def _initial_step(y0, f0, span, mu, rtol, atol, y1, f1):
    """Hairer's starting step (scipy's select_initial_step, order 7, no step limit); y1, f1 scratch."""
    n = y0.shape[0]
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        scale = atol + abs(y0[i]) * rtol
        d0 += (y0[i] / scale) ** 2
        d1 += (f0[i] / scale) ** 2
    d0 = np.sqrt(d0) / n**0.5
    d1 = np.sqrt(d1) / n**0.5
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, span)
    for i in range(n):
        y1[i] = y0[i] + h0 * f0[i]
    _rhs_into(y1, mu, f1)
    d2 = 0.0
    for i in range(n):
        d2 += ((f1[i] - f0[i]) / (atol + abs(y0[i]) * rtol)) ** 2
    d2 = np.sqrt(d2) / n**0.5 / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, span)


@njit(cache=True)
def _step(y, f, h, mu, k, y_new, stage):
    """One DOP853 step of size h from y, f = y' there (the CRTBP is autonomous): y_new, and k[0:13] the 12
    stages and y' at the step's end."""
    n = y.shape[0]
    for i in range(n):
        k[0, i] = f[i]
    for s in range(1, N_STAGES):
        _stage_input(y, h, A[s], k, s, stage)
        _rhs_into(stage, mu, k[s])
    for i in range(n):
        acc = 0.0
        for j in range(N_STAGES):
            acc += k[j, i] * B[j]
        y_new[i] = y[i] + h * acc
    _rhs_into(y_new, mu, k[N_STAGES])


@njit(cache=True)
def _error_norm(y, y_new, k, h, rtol, atol, e5, e3):
    """scipy's DOP853 error norm of the step in k; e5, e3 scratch."""
    n = y.shape[0]
    for i in range(n):
        scale = atol + max(abs(y[i]), abs(y_new[i])) * rtol
        acc5 = 0.0
        acc3 = 0.0
        for j in range(N_STAGES + 1):
            acc5 += k[j, i] * E5[j]
            acc3 += k[j, i] * E3[j]
        e5[i] = acc5 / scale
        e3[i] = acc3 / scale
    norm5 = _norm_squared(e5, n)
    norm3 = _norm_squared(e3, n)
    if norm5 == 0.0 and norm3 == 0.0:
        return 0.0
    return abs(h) * norm5 / np.sqrt((norm5 + 0.01 * norm3) * n)


@njit(cache=True)
def _dense_rows(y_old, y, f_old, f, h, mu, k, rows, stage):
    """The step's interpolant: its three extra stages into k[13:16], then rows (7, n) as scipy's
    Dop853DenseOutput holds them (y(t_old + x h) = y_old + a nested product of the rows in x and 1 - x)."""
    n = y.shape[0]
    for e in range(3):
        s = N_STAGES + 1 + e
        _stage_input(y_old, h, A_EXTRA[e], k, s, stage)  # the CRTBP is autonomous: no stage time
        _rhs_into(stage, mu, k[s])
    for i in range(n):
        delta = y[i] - y_old[i]
        rows[0, i] = delta
        rows[1, i] = h * f_old[i] - delta
        rows[2, i] = 2.0 * delta - h * (f[i] + f_old[i])
        for r in range(4):
            acc = 0.0
            for j in range(N_STAGES_EXTENDED):
                acc += D[r, j] * k[j, i]
            rows[3 + r, i] = h * acc


@njit(cache=True)
def _dense_value(rows, y_old, x, out):
    """out = y(t_old + x h) from the interpolant's rows."""
    n = y_old.shape[0]
    for i in range(n):
        acc = 0.0
        for r in range(6, -1, -1):
            acc += rows[r, i]
            if (6 - r) % 2 == 0:
                acc *= x
            else:
                acc *= 1.0 - x
        out[i] = acc + y_old[i]


@njit(cache=True)
def dop853_crtbp_into(y0, times, mu, rtol, atol, out):
    """The CRTBP state (6,) or [state, Phi row-major] (42,) y0 at times[0], integrated by adaptive DOP853 and
    sampled at times (m,) (ascending) into out (m, len(y0)). Returns (status, accepted steps, right-hand side
    evaluations): OK; STEP_TOO_SMALL where the step fell below ten units in the last place of t, NOT_FINITE
    where the step size is not finite (a field not finite at the start), TOO_MANY_STEPS past MAX_STEPS (out then
    holds the samples reached). The caller validates: y0 of length 6 or 42, finite ascending times, rtol and atol
    positive (dop853_samples_crtbp)."""
    n = y0.shape[0]
    m = times.shape[0]
    k = np.empty((N_STAGES_EXTENDED, n))
    y, f = y0.copy(), np.empty(n)
    y_new, stage = np.empty(n), np.empty(n)
    e5, e3 = np.empty(n), np.empty(n)
    rows = np.empty((7, n))
    t, t_bound = times[0], times[m - 1]
    done = 0
    while done < m and times[done] == t:  # the samples at the start are the start
        for i in range(n):  # an element loop: a slice assignment compiles numba's shape-error path (seconds)
            out[done, i] = y0[i]
        done += 1
    if done == m:
        return OK, 0, 0
    _rhs_into(y, mu, f)
    h_abs = _initial_step(y, f, abs(t_bound - t), mu, rtol, atol, y_new, stage)
    evaluations, steps = 2, 0
    while done < m:
        if steps >= MAX_STEPS:
            return TOO_MANY_STEPS, steps, evaluations
        if not np.isfinite(h_abs):
            return NOT_FINITE, steps, evaluations
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        rejected = False
        while True:
            if h_abs < min_step:
                return STEP_TOO_SMALL, steps, evaluations
            t_new = t + h_abs
            if t_new - t_bound > 0.0:
                t_new = t_bound
            h = t_new - t
            h_abs = abs(h)
            _step(y, f, h, mu, k, y_new, stage)
            evaluations += N_STAGES
            error = _error_norm(y, y_new, k, h, rtol, atol, e5, e3)
            if error < 1.0:
                factor = MAX_FACTOR
                if error != 0.0:
                    grown = SAFETY * error**ERROR_EXPONENT
                    factor = grown if grown < MAX_FACTOR else MAX_FACTOR
                if rejected and factor > 1.0:
                    factor = 1.0
                h_abs *= factor
                break
            shrunk = SAFETY * error**ERROR_EXPONENT
            h_abs *= shrunk if shrunk > MIN_FACTOR else MIN_FACTOR
            rejected = True
        steps += 1
        t_old = t
        t = t_new
        if done < m and times[done] <= t:
            _dense_rows(y, y_new, f, k[N_STAGES], h, mu, k, rows, stage)
            evaluations += 3
            span = t - t_old
            while done < m and times[done] <= t:
                _dense_value(rows, y, (times[done] - t_old) / span, out[done])
                done += 1
        for i in range(n):
            y[i] = y_new[i]
            f[i] = k[N_STAGES, i]
    return OK, steps, evaluations


FAILURES = {STEP_TOO_SMALL: "the step size fell below the spacing of the times",
            NOT_FINITE: "the field is not finite at the start", TOO_MANY_STEPS: f"more than {MAX_STEPS:,} steps"}
SMALLEST_RTOL = 100.0 * np.finfo(float).eps  # scipy raises a smaller rtol to this (validate_tol)


def dop853_samples_crtbp(y0, times_tu, mu, rtol, atol, what: str) -> np.ndarray:
    """y0 (6,) or (42,) at times_tu[0] sampled at times_tu (m,) (ascending): (m, len(y0)). Raises ValueError
    naming `what` for input the kernel cannot take (it reads 6 or 42 entries unchecked), RuntimeError if the
    integration fails (FAILURES). rtol below 100 eps is raised to it, as scipy does."""
    times_tu = np.ascontiguousarray(times_tu, dtype=float)
    y0 = np.ascontiguousarray(y0, dtype=float)
    if y0.ndim != 1 or y0.size not in (6, 42):
        raise ValueError(f"{what}: the start must be a state (6,) or a state and STM (42,), not shape {y0.shape}")
    if times_tu.ndim != 1 or times_tu.size == 0 or not np.all(np.isfinite(times_tu)) or np.any(
            np.diff(times_tu) < 0.0):
        raise ValueError(f"{what}: sample times must be a non-empty, finite, ascending sequence")
    if not (np.isfinite(rtol) and np.isfinite(atol) and rtol > 0.0 and atol > 0.0):
        raise ValueError(f"{what}: rtol and atol must be positive and finite, not {rtol} and {atol}")
    out = np.empty((times_tu.size, y0.size))
    status = dop853_crtbp_into(y0, times_tu, float(mu), max(float(rtol), SMALLEST_RTOL), float(atol), out)[0]
    if status != OK:
        raise RuntimeError(f"{what} failed: {FAILURES[status]}")
    return out


def dop853_states(state0_lu, times_tu, mu, rtol=TRUTH_RTOL, atol=TRUTH_ATOL) -> np.ndarray:
    """One CRTBP state (6,) sampled at times_tu (m,), times_tu[0] = its epoch: (m, 6). Raises RuntimeError
    if the integrator fails."""
    return dop853_samples_crtbp(state0_lu, times_tu, mu, rtol, atol, "truth propagation")


def dop853_state_stm(state0_lu, times_tu, mu, rtol=TRUTH_RTOL, atol=TRUTH_ATOL):
    """CRTBP state and STM Phi(t, t0) at times_tu (m,), times_tu[0] = t0: returns ((m, 6), (m, 6, 6))."""
    y0 = np.concatenate([np.asarray(state0_lu, dtype=float), np.eye(6).ravel()])
    y = dop853_samples_crtbp(y0, times_tu, mu, rtol, atol, "state+STM propagation")
    return y[:, :6].copy(), y[:, 6:].reshape(-1, 6, 6).copy()
