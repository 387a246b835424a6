"""Line-of-sight angles of the transponder seen from the receiver (001 §3.3, Eq. 22-23 geometry).

d = r_transponder - r_receiver in the rotating frame (a known rotation from any inertial or body frame
whose attitude is known): azimuth = atan2(d_y, d_x), elevation = atan2(d_z, sqrt(d_x^2 + d_y^2)).
Angle error from an interferometric baseline L (001 Eq. 8): a path-difference error sigma_path gives
sigma_angle = sigma_path / (L cos(theta)), theta the off-boresight angle (boresight: sigma_path / L).
"""

import numpy as np
from numba import njit


@njit(cache=True)
def azimuth_elevation(r_receiver, r_transponder):
    """(3,), (3,) -> (azimuth, elevation) in rad."""
    dx = r_transponder[0] - r_receiver[0]
    dy = r_transponder[1] - r_receiver[1]
    dz = r_transponder[2] - r_receiver[2]
    return np.arctan2(dy, dx), np.arctan2(dz, np.sqrt(dx * dx + dy * dy))


@njit(cache=True)
def azimuth_elevation_gradients(r_receiver, r_transponder):
    """d(azimuth)/d(r_receiver), d(elevation)/d(r_receiver): two (3,) arrays; the transponder's are their
    negatives. Singular at the poles (d_x = d_y = 0)."""
    dx = r_transponder[0] - r_receiver[0]
    dy = r_transponder[1] - r_receiver[1]
    dz = r_transponder[2] - r_receiver[2]
    h2 = dx * dx + dy * dy
    h = np.sqrt(h2)
    rho2 = h2 + dz * dz
    g_az = np.empty(3)
    g_el = np.empty(3)
    # Derivatives with respect to d, then times d(d)/d(r_receiver) = -I.
    g_az[0] = dy / h2
    g_az[1] = -dx / h2
    g_az[2] = 0.0
    g_el[0] = dz * dx / (rho2 * h)
    g_el[1] = dz * dy / (rho2 * h)
    g_el[2] = -h / rho2
    return g_az, g_el


def los_sigma_rad(path_sigma_m: float, baseline_m: float, off_boresight_deg: float = 0.0) -> float:
    """001 Eq. 8: angle 1-sigma from the path-difference (ranging) error over a baseline."""
    return path_sigma_m / (baseline_m * np.cos(np.radians(off_boresight_deg)))
