"""Line-of-sight angles of the transponder seen from the receiver (001 §3.3, Eq. 22-23 geometry).

d = r_transponder - r_receiver in the rotating frame (a known rotation from any inertial or body frame
whose attitude is known): azimuth = atan2(d_y, d_x), elevation = atan2(d_z, sqrt(d_x^2 + d_y^2)).
Angle error from an interferometric baseline L (001 Eq. 8): a path-difference error sigma_path gives
sigma_angle = sigma_path / (L cos(theta)), theta the off-boresight angle (boresight: sigma_path / L).
Truth: the instantaneous geometry at the reception time.
"""

import numpy as np
from numba import njit

from liaison_cli.compiled_calls import writable_c
from liaison_cli.measurements.observable import ChannelKind, Observable
from liaison_cli.measurements.range import write_position_partials

KIND_AZIMUTH = 2
KIND_ELEVATION = 3


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


@njit(cache=True, inline="always")
def predict_angle(code, x_receiver, x_transponder, g_receiver, g_transponder):
    """Azimuth (code KIND_AZIMUTH) or elevation (rad) and its partials with respect to both ends' states."""
    az, el = azimuth_elevation(x_receiver[0:3], x_transponder[0:3])
    g_az, g_el = azimuth_elevation_gradients(x_receiver[0:3], x_transponder[0:3])
    write_position_partials(g_az if code == KIND_AZIMUTH else g_el, g_receiver, g_transponder)
    return az if code == KIND_AZIMUTH else el


@njit(cache=True)
def wrap_angle(residual):
    """Into (-pi, pi]: an azimuth residual across the +-pi cut is small, not 2 pi."""
    return (residual + np.pi) % (2.0 * np.pi) - np.pi


def los_sigma_rad(path_sigma_m: float, baseline_m: float, off_boresight_deg: float = 0.0) -> float:
    """001 Eq. 8: angle 1-sigma from the path-difference (ranging) error over a baseline."""
    return path_sigma_m / (baseline_m * np.cos(np.radians(off_boresight_deg)))


def _simulate(code, receiver, transponder, light_time: bool):
    # Writable (copied only if read-only): one compiled signature of azimuth_elevation.
    receivers, transponders = (writable_c(end.states) for end in (receiver, transponder))
    angles = np.array([azimuth_elevation(a[:3], b[:3]) for a, b in zip(receivers, transponders)])
    return angles[:, 0] if code == KIND_AZIMUTH else angles[:, 1]


def _sigma(noise, receiver):
    sigma = los_sigma_rad(noise.resolved_los_path_sigma_m(), receiver.antenna_baseline_m)
    return (sigma, sigma)


OBSERVABLE = Observable(
    name="los",
    channels=(ChannelKind(KIND_AZIMUTH, "azimuth", "rad", 1.0), ChannelKind(KIND_ELEVATION, "elevation", "rad", 1.0)),
    sigma=_sigma,
    simulate=_simulate,
    needs_receiver_baseline=True,
    missing_noise=lambda noise: (None if noise.resolved_los_path_sigma_m() is not None
                                 else "give noise.los_path_sigma_m or noise.carrier"),
    description="line-of-sight azimuth and elevation from the receiver's interferometer (001 Eq. 8)",
)
