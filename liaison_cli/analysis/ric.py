"""Errors and sigmas in each spacecraft's radial / in-track / cross-track (RIC) frame, after the settle time.

The frame of a spacecraft at an epoch, from its true state relative to the nearer primary (the Earth or the
Moon; for a libration-point orbit usually the Moon): R along the relative position, C along the relative
angular momentum r x v, I = C x R (along the velocity for a circular orbit). In a CRTBP scenario the
velocities are the rotating frame's (the filter's state), the primaries at rest; in a dated one the
geocentric ICRF's, the Moon's velocity from its sampled positions. The filter's sigma along an axis u is
sqrt(u' P u) from the spacecraft's 3 x 3 position (or velocity) covariance block (estimation.filter_loop.
record_directions); the error along it is u'e.
"""

import numpy as np

from liaison_cli.dynamics.constants import TU_S

AXES = ("radial", "intrack", "crosstrack")


def primaries_lu(mu: float, body_positions: dict, times_s) -> np.ndarray:
    """(m, 2, 3) the Earth's and the Moon's positions at the epochs: a dated model's body_positions_lu
    ({'earth_lu', 'moon_lu'}), or, when empty, the CRTBP's fixed primaries (-mu, 0, 0) and (1 - mu, 0, 0)."""
    m = len(times_s)
    if not body_positions:
        return np.broadcast_to(np.array([[-mu, 0.0, 0.0], [1.0 - mu, 0.0, 0.0]]), (m, 2, 3)).copy()
    earth = np.broadcast_to(np.asarray(body_positions["earth_lu"], dtype=float), (m, 3))
    return np.stack([earth, np.asarray(body_positions["moon_lu"], dtype=float)], axis=1)


def ric_axes(position, velocity, primaries, primary_velocities) -> np.ndarray:
    """(m, 3, 3) rows R, I, C per epoch for one spacecraft: position, velocity (m, 3); primaries and their
    velocities (m, 2, 3) (primary_velocities: see primary_velocities_lu)."""
    rows = np.arange(len(position))
    nearer = np.argmin(np.sum((position[:, None, :] - primaries) ** 2, axis=2), axis=1)
    r = position - primaries[rows, nearer]
    v = velocity - primary_velocities[rows, nearer]
    radial = r / np.linalg.norm(r, axis=1, keepdims=True)
    normal = np.cross(r, v)
    cross = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    return np.stack([radial, np.cross(cross, radial), cross], axis=1)


def primary_velocities_lu(primaries, step_s: float) -> np.ndarray:
    """(m, 2, 3) LU/TU: the primaries' velocities from their positions sampled every step_s (central
    differences; 0 for one epoch)."""
    return np.gradient(primaries, step_s / TU_S, axis=0) if len(primaries) > 1 else np.zeros_like(primaries)


def _along(axis, packed) -> np.ndarray:
    """u' B u per epoch for unit vectors axis (k, 3) and symmetric blocks packed (k, 6) = xx, yy, zz, xy, xz, yz."""
    x, y, z = axis[:, 0], axis[:, 1], axis[:, 2]
    return (packed[:, 0] * x * x + packed[:, 1] * y * y + packed[:, 2] * z * z
            + 2.0 * (packed[:, 3] * x * y + packed[:, 4] * x * z + packed[:, 5] * y * z))


def ric_columns(times_s, err, truth, covariance, primaries, settle_s: float, to_m: float, to_m_s: float,
                primary_velocities=None) -> list:
    """Per spacecraft after settle_s, for position (m) and velocity (m/s) along R, I and C: the error RMS
    (rms_{axis}_{kind}_settled_{unit}), the mean error (mean_...: a bias), and the RMS of the filter's sigma
    (sigma_...). err, truth (m, 6 S) in LU, LU/TU; covariance (m, S, 12) or None (all NaN); primaries (m, 2, 3)
    and, when known, their velocities (else from the positions). The epochs are in time order, so the settled
    ones are a tail (views, no copies: this runs once per Monte Carlo run)."""
    times_s = np.asarray(times_s, dtype=float)
    if primary_velocities is None:
        primary_velocities = primary_velocities_lu(primaries, float(times_s[1] - times_s[0]) if len(times_s) > 1
                                                   else 1.0)
    tail = slice(int(np.searchsorted(times_s, settle_s)), None)
    primaries, primary_velocities = primaries[tail], primary_velocities[tail]
    rows = []
    for s in range(err.shape[1] // 6):
        row = {}
        state = truth[tail, 6 * s : 6 * s + 6]
        axes = ric_axes(state[:, :3], state[:, 3:], primaries, primary_velocities)
        for half, (kind, unit, scale) in enumerate((("position", "m", to_m), ("velocity", "m_s", to_m_s))):
            columns = slice(6 * s + 3 * half, 6 * s + 3 * half + 3)
            along = np.einsum("kaj,kj->ka", axes, err[tail, columns])
            ok = np.all(np.isfinite(along), axis=1)
            along = along[ok]
            blocks = covariance[tail, s, 6 * half : 6 * half + 6][ok] if covariance is not None else None
            for a, axis in enumerate(AXES):
                variance = _along(axes[ok, a, :], blocks) if blocks is not None else np.full(len(along), np.nan)
                empty = not len(along)
                row[f"rms_{axis}_{kind}_settled_{unit}"] = _rms(along[:, a]) * scale
                row[f"mean_{axis}_{kind}_settled_{unit}"] = (np.nan if empty else float(np.mean(along[:, a]))) * scale
                row[f"sigma_{axis}_{kind}_settled_{unit}"] = (np.nan if empty else float(np.sqrt(np.mean(variance)))
                                                              ) * scale
        rows.append(row)
    return rows


def _rms(values) -> float:
    return float(np.sqrt(np.mean(values * values))) if values.size else float("nan")
