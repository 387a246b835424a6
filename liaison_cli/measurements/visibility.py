"""Visibility of a channel: epochs at which a measurement can exist (others are blanked to NaN).

- Elevation mask: a ground station sees a spacecraft only above `mask_deg` over its local horizon
  (the plane normal to the station's geodetic up direction).
- Occultation: the straight line between the two ends must not pass through the Earth or the Moon
  (spheres of their mean radii at their CRTBP positions, or, in dated dynamics, where DE421 puts them).
"""

import numpy as np

from liaison_cli.dynamics.constants import (
    EARTH_POSITION_LU,
    EARTH_RADIUS_KM,
    LU_KM,
    MOON_POSITION_LU,
    MOON_RADIUS_KM,
)


def elevation_rad(station_positions, station_up, target_positions):
    """Elevation of the target above the station's horizon: (m, 3) x3 -> (m,) rad."""
    d = target_positions - station_positions
    d /= np.linalg.norm(d, axis=1)[:, None]
    return np.arcsin(np.clip(np.einsum("ij,ij->i", d, station_up), -1.0, 1.0))


def segment_clear_of_sphere(a, b, center, radius):
    """True where the segment a -> b (m, 3) stays outside the sphere (center (3,), radius)."""
    center = np.asarray(center, dtype=float)
    d = b - a
    t = np.clip(np.einsum("ij,ij->i", center - a, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
    closest = a + t[:, None] * d
    return np.linalg.norm(closest - center, axis=1) > radius


def not_occulted(a, b, earth_lu=EARTH_POSITION_LU, moon_lu=MOON_POSITION_LU, check_earth=True):
    """True where neither the Earth nor the Moon blocks the line between the two ends (m, 3) x2.

    earth_lu / moon_lu: the bodies' centres, (3,) fixed (CRTBP) or (m, 3) per epoch (dated dynamics).
    check_earth False: an end on the ground, whose elevation mask already stands for the Earth (its site
    may lie inside the mean-radius sphere, which would hide everything)."""
    clear = segment_clear_of_sphere(a, b, moon_lu, MOON_RADIUS_KM / LU_KM)
    if check_earth:
        clear &= segment_clear_of_sphere(a, b, earth_lu, EARTH_RADIUS_KM / LU_KM)
    return clear
