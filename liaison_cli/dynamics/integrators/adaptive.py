"""scipy's adaptive DOP853 behind one wrapper (`dop853_samples`: a right-hand side, sampled at given times,
restarted past every terminal event). The dated ephemeris truth
(dynamics.ephemeris_dynamics.dop853_ephemeris_states) calls it with its shadow-edge events; the CRTBP's
reference propagations are compiled (integrators.dop853: the same method without Python in the loop).

scipy is imported inside the wrapper, so worker processes, which unpickle problems but never propagate a
truth, skip its ~0.5 s import.
"""

import numpy as np

RESTART_STEP = 1e-6  # past a terminal event, in the units of t


def dop853_samples(rhs, t0, y0, times, rtol, atol, events=(), what="propagation"):
    """y' = rhs(t, y) from y0 at t0 by scipy's adaptive DOP853, sampled at times (m,) (ascending, from t0):
    returns (m, len(y0)). A terminal event stops the integration, which restarts RESTART_STEP past it (one
    Euler step there): the integrator steps onto the right-hand side's kinks instead of across them. Raises
    RuntimeError naming `what` if the integrator fails."""
    from scipy.integrate import solve_ivp

    times = np.asarray(times, dtype=float)
    y = np.asarray(y0, dtype=float)
    states = np.empty((times.size, y.size))
    t, done = float(t0), 0
    if times[0] == t:
        states[0], done = y, 1
    while done < times.size:
        sol = solve_ivp(rhs, (t, times[-1]), y, method="DOP853", t_eval=times[done:], rtol=rtol, atol=atol,
                        events=list(events) or None)
        if not sol.success:
            raise RuntimeError(f"{what} failed: {sol.message}")
        n = len(sol.t)
        if n:
            states[done : done + n] = np.asarray(sol.y).T
        done += n
        if sol.status == 1:  # stopped on an event: restart just past it
            hit = min((te[0], ye[0]) for te, ye in zip(sol.t_events, sol.y_events) if len(te))
            t, y = hit[0] + RESTART_STEP, hit[1] + RESTART_STEP * rhs(hit[0], hit[1])
        elif done < times.size:
            raise RuntimeError(f"{what} ended early")
    return states
