"""The compiled adaptive DOP853 (integrators.dop853) against scipy's solve_ivp(method="DOP853") on the same
right-hand sides: the same steps (equal counts of right-hand-side evaluations, which any different accept,
reject or step size would change) and the same samples to rounding.

Tolerance: 2e-10 relative (to max(1, |value|)) over 2 TU with its STM. scipy differs from itself by up to
6.8e-11 on such propagations across BLAS kernels (host against OPENBLAS_CORETYPE=Sandybridge and Nehalem,
3 TU of 18 catalogue members; scipy 1.17.1, measured 2026-11-30): its stage sums are BLAS products. The
compiled sums run in a fixed order, so the two agree as two kernels do. Unstable members grow a rounding
difference along the STM's largest direction, hence a bound on the STM's scale.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from liaison_cli.dynamics.constants import MU
from liaison_cli.dynamics.crtbp import derivative, jacobi_constant, state_stm_derivative
from liaison_cli.dynamics.integrators.dop853 import (SMALLEST_RTOL, dop853_crtbp_into, dop853_samples_crtbp,
                                                     dop853_state_stm, dop853_states)
from liaison_cli.orbits.family_catalogue import shipped_table

RTOL, ATOL = 1e-13, 1e-14  # the corrector's (orbits.periodic)
TOLERANCE = 2e-10


def _member(family: str, fraction: float) -> tuple[np.ndarray, float]:
    """A shipped member's initial state (6,) and period (TU)."""
    table = shipped_table(family)
    row = int(fraction * (len(table) - 1))
    state = np.array([table[key][row] for key in ("x0", "y0", "z0", "vx0", "vy0", "vz0")])
    return state, float(table.period_tu[row])


@pytest.mark.parametrize("family, fraction, start, rtol", [("l2_nrho_south", 0.5, 0.0, RTOL),
                                                           ("l1_halo_south", 0.0, 5.0, RTOL),
                                                           ("dro", 1.0, 0.0, RTOL),
                                                           ("l2_lyapunov", 0.5, 0.0, 1e-15)])  # raised to 100 eps
@pytest.mark.parametrize("with_stm", [False, True])
def test_the_same_steps_and_samples_as_scipy(family, fraction, start, rtol, with_stm):
    import warnings

    state = _member(family, fraction)[0]
    y0 = np.concatenate([state, np.eye(6).ravel()]) if with_stm else state
    rhs = (lambda t, y: state_stm_derivative(y, MU)) if with_stm else (lambda t, y: derivative(y, MU))
    times = start + np.array([0.0, 0.3, 0.7, 1.2, 2.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # scipy's note that it raised rtol to 100 eps
        theirs = solve_ivp(rhs, (times[0], times[-1]), y0, method="DOP853", t_eval=times[1:], rtol=rtol, atol=ATOL)
    ours = dop853_samples_crtbp(y0, times, MU, rtol, ATOL, "a test")
    counted = np.empty((times.size, y0.size))
    status, steps, evaluations = dop853_crtbp_into(y0, times, MU, max(rtol, SMALLEST_RTOL), ATOL, counted)
    assert status == 0 and steps > 20 and np.array_equal(counted, ours)
    assert evaluations == theirs.nfev
    expected = theirs.y.T
    assert np.array_equal(ours[0], y0)  # the start sample is the start itself
    difference = np.abs(ours[1:] - expected) / np.maximum(1.0, np.abs(expected))
    assert difference.max() < TOLERANCE, difference.max()


def test_the_jacobi_integral_is_kept_over_an_nrho_period():
    state, period = _member("l2_nrho_south", 0.5)
    states = dop853_states(state, np.linspace(0.0, period, 50), MU, RTOL, ATOL)
    drift = max(abs(jacobi_constant(s, MU) - jacobi_constant(state, MU)) for s in states)
    assert drift < 1e-11, drift
    assert np.max(np.abs(states[-1] - state)) < 1e-9  # the corrected member closes


def test_the_stm_matches_central_differences():
    state = _member("l1_halo_south", 0.5)[0]
    times = np.array([0.0, 1.0])
    phi = dop853_state_stm(state, times, MU, RTOL, ATOL)[1][-1]
    step = 1e-6
    columns = []
    for j in range(6):
        plus, minus = state.copy(), state.copy()
        plus[j] += step
        minus[j] -= step
        columns.append((dop853_states(plus, times, MU, RTOL, ATOL)[-1]
                        - dop853_states(minus, times, MU, RTOL, ATOL)[-1]) / (2.0 * step))
    assert np.allclose(np.column_stack(columns), phi, rtol=1e-6, atol=1e-6)


def test_repeated_samples_are_the_same_sample():
    state = _member("dro", 0.5)[0]
    assert np.array_equal(dop853_states(state, np.array([0.5, 0.5]), MU), np.vstack([state, state]))
    once = dop853_states(state, np.array([0.0, 0.4, 1.0]), MU)
    repeated = dop853_states(state, np.array([0.0, 0.0, 0.4, 0.4, 1.0]), MU)
    assert np.array_equal(repeated, once[[0, 0, 1, 1, 2]])


def test_a_start_that_is_not_finite_is_one_message_not_a_silent_nan():
    broken = np.array([np.nan, 0.0, 0.0, 0.0, 0.1, 0.0])
    with pytest.raises(RuntimeError, match="truth propagation failed: the field is not finite at the start"):
        dop853_states(broken, np.array([0.0, 1.0]), MU)


@pytest.mark.parametrize("y0, times, tolerances, fragment", [
    (np.zeros(7), [0.0, 1.0], (1e-12, 1e-13), "not shape (7,)"),  # the kernel reads 6 or 42 entries unchecked
    (np.zeros((2, 6)), [0.0, 1.0], (1e-12, 1e-13), "not shape (2, 6)"),
    (np.ones(6), [0.0, np.nan], (1e-12, 1e-13), "finite, ascending"),
    (np.ones(6), [0.0, np.inf], (1e-12, 1e-13), "finite, ascending"),
    (np.ones(6), [0.0, 1.0], (1e-12, 0.0), "positive and finite"),
])
def test_input_the_kernel_cannot_take_is_refused(y0, times, tolerances, fragment):
    with pytest.raises(ValueError, match="a test") as refused:
        dop853_samples_crtbp(y0, np.array(times), MU, *tolerances, "a test")
    assert fragment in str(refused.value)


def test_a_path_that_never_ends_is_bounded():
    """Flung from the Moon's centre (a field of 1e31) the step sequence shrinks without end; the compiled loop,
    which Ctrl-C cannot interrupt, stops at MAX_STEPS with one message."""
    at_the_moon = np.array([1.0 - MU, 0.0, 0.0, 0.0, 0.1, 0.0])
    with pytest.raises(RuntimeError, match="more than 500,000 steps"):
        dop853_states(at_the_moon, np.array([0.0, 1.0]), MU)


def test_descending_times_are_refused():
    with pytest.raises(ValueError, match="ascending"):
        dop853_states(_member("dro", 0.5)[0], np.array([1.0, 0.0]), MU)
