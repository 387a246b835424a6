"""High-accuracy propagation of truth trajectories (scipy DOP853 over the compiled CRTBP derivative)."""

import numpy as np

from liaison_cli.dynamics.crtbp import derivative, state_stm_derivative

TRUTH_RTOL = 1e-12
TRUTH_ATOL = 1e-13


def propagate_states(state0_lu, times_tu, mu, rtol=TRUTH_RTOL, atol=TRUTH_ATOL):
    """Propagate one spacecraft state (6,) and sample it at times_tu (m,), times_tu[0] = epoch.

    Returns an (m, 6) array. Raises RuntimeError if the integrator fails.
    """
    # Imported here so worker processes, which unpickle Problems but never propagate truth, skip ~0.5 s.
    from scipy.integrate import solve_ivp

    times_tu = np.asarray(times_tu, dtype=float)
    state0_lu = np.asarray(state0_lu, dtype=float)
    if times_tu.size == 1:
        return state0_lu[None, :].copy()
    sol = solve_ivp(
        lambda t, s: derivative(s, mu),
        (times_tu[0], times_tu[-1]),
        state0_lu,
        method="DOP853",
        t_eval=times_tu,
        rtol=rtol,
        atol=atol,
    )
    if not sol.success:
        raise RuntimeError(f"truth propagation failed: {sol.message}")
    return sol.y.T.copy()


def dop853_state_stm(state0_lu, times_tu, mu, rtol=TRUTH_RTOL, atol=TRUTH_ATOL):
    """State and STM Phi(t, t0) at times_tu (m,), times_tu[0] = t0: returns ((m, 6), (m, 6, 6))."""
    from scipy.integrate import solve_ivp

    times_tu = np.asarray(times_tu, dtype=float)
    y0 = np.concatenate([np.asarray(state0_lu, dtype=float), np.eye(6).ravel()])
    if times_tu.size == 1 or times_tu[-1] == times_tu[0]:
        y = np.repeat(y0[None, :], times_tu.size, axis=0)
    else:
        sol = solve_ivp(lambda t, y: state_stm_derivative(y, mu), (times_tu[0], times_tu[-1]), y0,
                        method="DOP853", t_eval=times_tu, rtol=rtol, atol=atol)
        if not sol.success:
            raise RuntimeError(f"state+STM propagation failed: {sol.message}")
        y = sol.y.T
    return y[:, :6].copy(), y[:, 6:].reshape(-1, 6, 6).copy()
