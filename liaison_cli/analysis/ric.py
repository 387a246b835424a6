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
from numba import njit

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


def ric_columns(times_s, err, truth, covariance, primaries, settle_s: float, to_m: float, to_m_s: float,
                primary_velocities=None) -> list:
    """Per spacecraft after settle_s, for position (m) and velocity (m/s) along R, I and C: the error RMS
    (rms_{axis}_{kind}_settled_{unit}), the mean error (mean_...: a bias), and the RMS of the filter's sigma
    (sigma_...). err, truth (m, 6 S) in LU, LU/TU; covariance (m, S, 12) or None (all NaN); primaries (m, 2, 3)
    and, when known, their velocities (else from the positions). The epochs are in time order, so the settled
    ones are a tail; with a covariance record, its recorded epochs among them. The sums run compiled
    (_ric_sums): this runs once per Monte Carlo run, and in NumPy it cost a quarter of an EKF run."""
    times_s = np.asarray(times_s, dtype=float)
    if primary_velocities is None:
        primary_velocities = primary_velocities_lu(primaries, float(times_s[1] - times_s[0]) if len(times_s) > 1
                                                   else 1.0)
    first = int(np.searchsorted(times_s, settle_s))
    n_spacecraft = err.shape[1] // 6
    blocks = covariance if covariance is not None else np.full((len(times_s), n_spacecraft, 12), np.nan)
    recorded = np.flatnonzero(np.isfinite(blocks[first:, 0, 0])) + first if covariance is not None else np.zeros(0)
    rows_used = recorded if len(recorded) else np.arange(first, len(times_s))
    sums = _ric_sums(np.ascontiguousarray(truth), np.ascontiguousarray(err), np.ascontiguousarray(blocks),
                     np.ascontiguousarray(primaries), np.ascontiguousarray(primary_velocities),
                     rows_used.astype(np.int64), n_spacecraft)
    rows = []
    for s in range(n_spacecraft):
        row = {}
        for half, (kind, unit, scale) in enumerate((("position", "m", to_m), ("velocity", "m_s", to_m_s))):
            for a, axis in enumerate(AXES):
                count, total, squares, variance = sums[s, half, a]
                empty = count == 0
                row[f"rms_{axis}_{kind}_settled_{unit}"] = np.nan if empty else float(np.sqrt(squares / count)) * scale
                row[f"mean_{axis}_{kind}_settled_{unit}"] = np.nan if empty else float(total / count) * scale
                row[f"sigma_{axis}_{kind}_settled_{unit}"] = (np.nan if empty or covariance is None
                                                              else float(np.sqrt(variance / count)) * scale)
        rows.append(row)
    return rows


@njit(cache=True)
def _ric_sums(truth, err, blocks, primaries, primary_velocities, rows, n_spacecraft):
    """(S, 2, 3, 4): per spacecraft, position / velocity and R / I / C axis, over the given epochs with a finite
    error: [count, sum of the error along the axis, sum of its square, sum of the covariance along the axis]
    (ric_axes' frame, written out per epoch)."""
    out = np.zeros((n_spacecraft, 2, 3, 4))
    axes = np.empty((3, 3))
    # Scalar arithmetic throughout (the same operations as np.cross and slice division): array expressions and
    # slice assignment made numba compile their shape-error paths, 4 s of a first run.
    for k in rows:
        for s in range(n_spacecraft):
            a0 = 6 * s
            best, nearer = np.inf, 0
            for b in range(2):
                d = ((truth[k, a0] - primaries[k, b, 0]) ** 2 + (truth[k, a0 + 1] - primaries[k, b, 1]) ** 2
                     + (truth[k, a0 + 2] - primaries[k, b, 2]) ** 2)
                if d < best:
                    best, nearer = d, b
            rx, ry, rz = (truth[k, a0] - primaries[k, nearer, 0], truth[k, a0 + 1] - primaries[k, nearer, 1],
                          truth[k, a0 + 2] - primaries[k, nearer, 2])
            vx, vy, vz = (truth[k, a0 + 3] - primary_velocities[k, nearer, 0],
                          truth[k, a0 + 4] - primary_velocities[k, nearer, 1],
                          truth[k, a0 + 5] - primary_velocities[k, nearer, 2])
            nx, ny, nz = ry * vz - rz * vy, rz * vx - rx * vz, rx * vy - ry * vx
            distance = np.sqrt(rx * rx + ry * ry + rz * rz)
            momentum = np.sqrt(nx * nx + ny * ny + nz * nz)
            if not (distance > 0.0 and momentum > 0.0):  # no frame at this epoch (radial motion): left out
                continue
            axes[0, 0], axes[0, 1], axes[0, 2] = rx / distance, ry / distance, rz / distance
            axes[2, 0], axes[2, 1], axes[2, 2] = nx / momentum, ny / momentum, nz / momentum
            axes[1, 0] = axes[2, 1] * axes[0, 2] - axes[2, 2] * axes[0, 1]
            axes[1, 1] = axes[2, 2] * axes[0, 0] - axes[2, 0] * axes[0, 2]
            axes[1, 2] = axes[2, 0] * axes[0, 1] - axes[2, 1] * axes[0, 0]
            for half in range(2):
                e0 = a0 + 3 * half
                ex, ey, ez = err[k, e0], err[k, e0 + 1], err[k, e0 + 2]
                if not (np.isfinite(ex) and np.isfinite(ey) and np.isfinite(ez)):
                    continue
                c = 6 * half
                for a in range(3):
                    x, y, z = axes[a, 0], axes[a, 1], axes[a, 2]
                    along = x * ex + y * ey + z * ez
                    out[s, half, a, 0] += 1.0
                    out[s, half, a, 1] += along
                    out[s, half, a, 2] += along * along
                    out[s, half, a, 3] += (blocks[k, s, c] * x * x + blocks[k, s, c + 1] * y * y
                                           + blocks[k, s, c + 2] * z * z
                                           + 2.0 * (blocks[k, s, c + 3] * x * y + blocks[k, s, c + 4] * x * z
                                                    + blocks[k, s, c + 5] * y * z))
    return out
