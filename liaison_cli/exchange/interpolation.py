"""An OEM's states between its lines, as its INTERPOLATION says: LAGRANGE (position and velocity each a
polynomial through the degree + 1 nearest lines), HERMITE (positions matched with their velocities as
derivatives, (degree + 1) / 2 lines rounded up), LINEAR (degree 1). An epoch on a line returns that line."""

import numpy as np

METHODS = ("LAGRANGE", "HERMITE", "LINEAR")


def _window(times_s: np.ndarray, t: float, points: int) -> slice:
    """The `points` lines nearest t, centred where the file allows."""
    right = int(np.searchsorted(times_s, t))
    start = min(max(0, right - points // 2), max(0, len(times_s) - points))
    return slice(start, start + points)


def _lagrange(x: np.ndarray, y: np.ndarray, t: float) -> np.ndarray:
    """The polynomial through (x, y rows) at t (callers shift x and t to the window's first line: small
    products)."""
    out = np.zeros(y.shape[1])
    for j in range(len(x)):
        weight = 1.0
        for k in range(len(x)):
            if k != j:
                weight *= (t - x[k]) / (x[j] - x[k])
        out += weight * y[j]
    return out


def _hermite(x: np.ndarray, position: np.ndarray, velocity: np.ndarray, t: float) -> np.ndarray:
    from scipy.interpolate import KroghInterpolator

    nodes = np.repeat(x - x[0], 2)
    values = np.empty((2 * len(x), 3))
    values[0::2], values[1::2] = position, velocity
    curve = KroghInterpolator(nodes, values)
    derivatives = curve.derivatives(t - x[0], der=2)
    return np.concatenate([derivatives[0], derivatives[1]])


def interpolate_states(times_s, states, at_s, method: str, degree: int) -> np.ndarray:
    """States (n, 6) of the lines at times_s (n,), increasing, at the epochs at_s (k,) -> (k, 6)."""
    times_s, states = np.asarray(times_s, dtype=float), np.asarray(states, dtype=float)
    out = np.empty((len(at_s), 6))
    hit = np.searchsorted(times_s, at_s)
    for i, t in enumerate(np.asarray(at_s, dtype=float)):
        if hit[i] < len(times_s) and times_s[hit[i]] == t:
            out[i] = states[hit[i]]
            continue
        if method == "HERMITE":
            window = _window(times_s, t, max(2, (degree + 2) // 2))
            out[i] = _hermite(times_s[window], states[window, :3], states[window, 3:], t)
        else:
            window = _window(times_s, t, 2 if method == "LINEAR" else degree + 1)
            x = times_s[window]
            out[i] = _lagrange(x - x[0], states[window], t - x[0])
    return out
