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

AXES = ("radial", "intrack", "crosstrack")


def primaries_lu(mu: float, body_positions: dict, times_s) -> np.ndarray:
    """(m, 2, 3) the Earth's and the Moon's positions at the epochs: a dated model's body_positions_lu
    ({'earth_lu', 'moon_lu'}), or, when empty, the CRTBP's fixed primaries (-mu, 0, 0) and (1 - mu, 0, 0)."""
    m = len(times_s)
    if not body_positions:
        return np.broadcast_to(np.array([[-mu, 0.0, 0.0], [1.0 - mu, 0.0, 0.0]]), (m, 2, 3)).copy()
    earth = np.broadcast_to(np.asarray(body_positions["earth_lu"], dtype=float), (m, 3))
    return np.stack([earth, np.asarray(body_positions["moon_lu"], dtype=float)], axis=1)


def ric_axes(position, velocity, primaries, dt) -> np.ndarray:
    """(m, 3, 3) rows R, I, C per epoch for one spacecraft: position, velocity (m, 3), primaries (m, 2, 3), dt
    the epoch spacing (for the primaries' velocities by finite differences)."""
    distances = np.linalg.norm(position[:, None, :] - primaries, axis=2)
    nearer = np.argmin(distances, axis=1)
    centre = primaries[np.arange(len(position)), nearer]
    centre_velocity = np.gradient(primaries, dt, axis=0)[np.arange(len(position)), nearer] if len(position) > 1 \
        else np.zeros_like(centre)
    r = position - centre
    v = velocity - centre_velocity
    radial = r / np.linalg.norm(r, axis=1, keepdims=True)
    normal = np.cross(r, v)
    cross = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    return np.stack([radial, np.cross(cross, radial), cross], axis=1)


def _block(packed) -> np.ndarray:
    """(m, 3, 3) from (m, 6) = xx, yy, zz, xy, xz, yz."""
    xx, yy, zz, xy, xz, yz = (packed[:, i] for i in range(6))
    return np.stack([np.stack([xx, xy, xz], 1), np.stack([xy, yy, yz], 1), np.stack([xz, yz, zz], 1)], 1)


def ric_columns(times_s, err, truth, covariance, primaries, settle_s: float, to_m: float, to_m_s: float) -> list:
    """Per spacecraft after settle_s, for position (m) and velocity (m/s) along R, I and C: the error RMS
    (rms_{axis}_{kind}_settled_{unit}), the mean error (mean_...: a bias), and the RMS of the filter's sigma
    (sigma_...). err, truth (m, 6 S) in LU, LU/TU; covariance (m, S, 12) or None (all NaN)."""
    times_s = np.asarray(times_s, dtype=float)
    settled = times_s >= settle_s
    dt = float(times_s[1] - times_s[0]) if len(times_s) > 1 else 1.0
    n_spacecraft = err.shape[1] // 6
    rows = []
    for s in range(n_spacecraft):
        row = {}
        state = truth[:, 6 * s : 6 * s + 6]
        axes = ric_axes(state[:, :3], state[:, 3:], primaries, dt)[settled]
        for half, (kind, unit, scale) in enumerate((("position", "m", to_m), ("velocity", "m_s", to_m_s))):
            e = np.einsum("kij,kj->ki", axes, err[settled, 6 * s + 3 * half : 6 * s + 3 * half + 3])
            if covariance is None:
                variance = np.full(e.shape, np.nan)
            else:
                block = _block(covariance[settled, s, 6 * half : 6 * half + 6])
                variance = np.einsum("kij,kjl,kil->ki", axes, block, axes)
            for a, axis in enumerate(AXES):
                ok = np.isfinite(e[:, a])
                row[f"rms_{axis}_{kind}_settled_{unit}"] = _rms(e[ok, a]) * scale
                row[f"mean_{axis}_{kind}_settled_{unit}"] = (float(np.mean(e[ok, a])) if ok.any() else np.nan) * scale
                row[f"sigma_{axis}_{kind}_settled_{unit}"] = _rms(np.sqrt(variance[ok, a])) * scale
        rows.append(row)
    return rows


def _rms(values) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(values * values))) if values.size else float("nan")
