"""Earth orientation for ground stations on a dated Earth (003: DSN tracking): ITRF -> GCRF through ERFA.

r_GCRF = Q(X, Y, s) R3(-ERA) W(x_p, y_p, s') r_ITRF (IERS Conventions 2010, the CIO-based transformation):
- X, Y, s: the CIP and CIO locator of IAU 2006 precession / IAU 2000A nutation (erfa.xys06a), evaluated
  on an hourly grid of TT and linear between (error below 3e-11 rad, 0.2 mm on the ground, tested);
- ERA: the Earth rotation angle of UT1 (erfa.era00), UT1 - UTC from the IERS file (dynamics.iers_eop);
- W: polar motion x_p, y_p from the same file, with the TIO locator s' (erfa.pom00, erfa.sp00).
UTC -> TT as in dynamics.timescales. Beyond the IERS predictions the Earth orientation parameters are held
(dynamics.iers_eop's rule). Stations agree with skyfield's, given the same IERS file, to 0.2 mm
(tests/unit/dynamics/test_earth_rotation.py). Station coordinates are WGS84 geodetic (dynamics.ground_station).
Units: km, rad, s.
"""

import math
import warnings
from datetime import datetime

import numpy as np

from liaison_cli.dynamics.constants import EARTH_ROTATION_RATE_RAD_S
from liaison_cli.dynamics.ground_station import geodetic_to_body_km
from liaison_cli.dynamics.iers_eop import eop_at
from liaison_cli.dynamics.timescales import J2000_JD, utc_to_tt_two_part

CIP_GRID_STEP_DAYS = 1.0 / 24.0
# Below this many epochs X, Y, s are evaluated at each epoch: the grid would cost more than it saves.
CIP_DIRECT_MAX_EPOCHS = 48


def cip_xys(tt1, tt2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """X, Y, s (rad, each (m,)) at TT two-part Julian dates: erfa.xys06a on an hourly grid covering the
    epochs, linear between the grid's values (direct evaluation for a few epochs)."""
    import erfa

    tt_days = (np.asarray(tt1) - J2000_JD) + np.asarray(tt2)
    if tt_days.size <= CIP_DIRECT_MAX_EPOCHS:
        return erfa.xys06a(np.full(tt_days.shape, J2000_JD), tt_days)
    first = math.floor(tt_days.min() / CIP_GRID_STEP_DAYS) * CIP_GRID_STEP_DAYS
    n_nodes = int(math.ceil((tt_days.max() - first) / CIP_GRID_STEP_DAYS)) + 2
    nodes = first + CIP_GRID_STEP_DAYS * np.arange(n_nodes)
    x, y, s = erfa.xys06a(np.full(n_nodes, J2000_JD), nodes)
    return np.interp(tt_days, nodes, x), np.interp(tt_days, nodes, y), np.interp(tt_days, nodes, s)


def itrf_to_gcrf_many(moments) -> np.ndarray:
    """The rotations (m, 3, 3) from the Earth-fixed frame to GCRF at UTC moments (see module docstring)."""
    import erfa

    (utc1, utc2), (tt1, tt2) = utc_to_tt_two_part(moments)
    ut1_minus_utc, xp, yp = eop_at(moments)
    with warnings.catch_warnings():  # 'dubious year' past pyerfa's release: dynamics.timescales' rule
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        ut11, ut12 = erfa.utcut1(utc1, utc2, ut1_minus_utc)
    x, y, s = cip_xys(tt1, tt2)
    celestial_to_intermediate = erfa.c2ixys(x, y, s)
    polar_motion = erfa.pom00(xp, yp, erfa.sp00(tt1, tt2))
    gcrs_to_itrs = erfa.c2tcio(celestial_to_intermediate, erfa.era00(ut11, ut12), polar_motion)
    return np.ascontiguousarray(np.transpose(gcrs_to_itrs, (0, 2, 1)))


def itrf_to_gcrf(moment: datetime) -> np.ndarray:
    """The rotation (3, 3) from the Earth-fixed frame to GCRF at one UTC moment."""
    return itrf_to_gcrf_many([moment])[0]


def stations_gcrf(latitude_deg: float, longitude_deg: float, height_m: float, rotations):
    """A station's GCRF positions (m, 3) km, velocities (m, 3) km/s (the Earth's spin) and local up (m, 3)
    under rotations (m, 3, 3) from itrf_to_gcrf_many."""
    r_itrf, up_itrf = geodetic_to_body_km(latitude_deg, longitude_deg, height_m)
    v_itrf = np.cross([0.0, 0.0, EARTH_ROTATION_RATE_RAD_S], r_itrf)
    return rotations @ r_itrf, rotations @ v_itrf, rotations @ up_itrf


def station_gcrf(latitude_deg: float, longitude_deg: float, height_m: float, moment: datetime):
    """A station's GCRF position (km), velocity (km/s, the Earth's spin) and local up (unit) at a UTC moment."""
    r, v, up = stations_gcrf(latitude_deg, longitude_deg, height_m, itrf_to_gcrf_many([moment]))
    return r[0], v[0], up[0]


def elevation_deg(station_km, up, target_km) -> float:
    line = np.asarray(target_km) - np.asarray(station_km)
    return math.degrees(math.asin(float(line @ up) / float(np.linalg.norm(line))))

