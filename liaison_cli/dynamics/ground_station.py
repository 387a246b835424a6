"""Ground stations on a rotating Earth, in the Earth-Moon CRTBP frame.

The CRTBP has no calendar, so the Earth model is idealised and stated: the Earth's centre sits at
(-mu, 0, 0); its spin axis is the rotating frame's z axis; it turns at the sidereal rate
EARTH_ROTATION_RATE_RAD_S relative to inertial space, hence at (rate * TU_S - 1) rad/TU relative to the
rotating frame. A station's longitude is counted east from the +x axis (the Earth-Moon line) at t0.
Station positions come from geodetic latitude, longitude and height on the WGS84 ellipsoid; `up` is the
geodetic normal (the horizon for elevation masks).
"""

import numpy as np

from liaison_cli.dynamics.constants import (
    EARTH_POSITION_LU,
    EARTH_ROTATION_RATE_RAD_S,
    LU_KM,
    TU_S,
    WGS84_EQUATORIAL_RADIUS_KM,
    WGS84_FLATTENING,
)
from liaison_cli.dynamics.trajectory import rotate_to_inertial_now

EARTH_RATE_IN_ROTATING_FRAME_RAD_TU = EARTH_ROTATION_RATE_RAD_S * TU_S - 1.0


def geodetic_to_body_km(latitude_deg, longitude_deg, altitude_m):
    """Earth-fixed position (3,) km and geodetic up unit vector (3,) on the WGS84 ellipsoid."""
    lat, lon = np.radians(latitude_deg), np.radians(longitude_deg)
    e2 = WGS84_FLATTENING * (2.0 - WGS84_FLATTENING)
    n = WGS84_EQUATORIAL_RADIUS_KM / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)  # prime-vertical radius
    h = altitude_m / 1e3
    up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    position = np.array([(n + h) * np.cos(lat) * np.cos(lon), (n + h) * np.cos(lat) * np.sin(lon),
                         (n * (1.0 - e2) + h) * np.sin(lat)])
    return position, up


def _rotate_z(vectors, angles):
    c, s = np.cos(angles), np.sin(angles)
    return np.stack([c * vectors[..., 0] - s * vectors[..., 1], s * vectors[..., 0] + c * vectors[..., 1],
                     np.broadcast_to(vectors[..., 2], c.shape)], axis=-1)


class GroundStationTrajectory:
    """A station's rotating-frame states (m, 6) and up vectors (m, 3) at times_tu (m,)."""

    rotating_frame = True

    def __init__(self, latitude_deg, longitude_deg, altitude_m, times_tu):
        body_km, up = geodetic_to_body_km(latitude_deg, longitude_deg, altitude_m)
        self.body_lu = body_km / LU_KM
        self.body_up = up
        self.times_tu = np.asarray(times_tu, dtype=float)
        self.states = self._states(self.times_tu)
        self.up = _rotate_z(np.broadcast_to(up, (len(self.times_tu), 3)), self._angle(self.times_tu))

    @staticmethod
    def _angle(times_tu):
        return EARTH_RATE_IN_ROTATING_FRAME_RAD_TU * times_tu

    def _states(self, times_tu):
        rel = _rotate_z(np.broadcast_to(self.body_lu, (len(times_tu), 3)), self._angle(times_tu))
        velocity = EARTH_RATE_IN_ROTATING_FRAME_RAD_TU * np.stack([-rel[:, 1], rel[:, 0], np.zeros(len(rel))], axis=1)
        return np.hstack([rel + np.asarray(EARTH_POSITION_LU), velocity])

    @property
    def accelerations(self) -> np.ndarray:
        """(m, 3) rotating-frame accelerations: the centripetal w^2 of the station's turn about the Earth's
        axis at w = EARTH_RATE_IN_ROTATING_FRAME_RAD_TU (the frame's own turn is not in it)."""
        rel = self.states[:, 0:3] - np.asarray(EARTH_POSITION_LU)
        w2 = EARTH_RATE_IN_ROTATING_FRAME_RAD_TU**2
        return np.stack([-w2 * rel[:, 0], -w2 * rel[:, 1], np.zeros(len(rel))], axis=1)

    def inertial_position_before(self, dt_back_tu):
        """Exact: the station's rotating-frame position at t - dt, turned into the inertial frame of t."""
        then = self._states(self.times_tu - dt_back_tu)[:, 0:3]
        return rotate_to_inertial_now(then, dt_back_tu)
