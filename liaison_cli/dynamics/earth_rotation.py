"""Earth orientation for ground stations on a dated Earth (003: DSN tracking): ITRF -> GCRF.

r_GCRF = P(TT) N(TT) R3(-GAST) r_ITRF, with
- P: IAU 1976 precession (Lieske angles zeta, z, theta);
- N: IAU 1980 nutation, its 13 largest terms (the rest are each below 0.01", together a few 0.01": ~1 m);
- GAST = GMST (IAU 1982, on UT1) + the equation of the equinoxes (dpsi cos eps);
- UT1 - UTC from the IERS finals2000A.all file shipped with skyfield-data (Bulletin A column), linear
  between its daily values.
Polar motion (at most ~0.5", ~15 m on the ground) and the frame bias (23 mas, < 1 m) are left out, as
skyfield leaves polar motion out by default; stations agree with skyfield's to a few metres
(tests/test_earth_rotation.py). Station coordinates are WGS84 geodetic (dynamics.ground_station). Units: km, rad, s.
"""

import math
import os
from datetime import datetime, timezone

import numpy as np

from liaison_cli.dynamics.constants import EARTH_ROTATION_RATE_RAD_S
from liaison_cli.dynamics.ground_station import geodetic_to_body_km
from liaison_cli.dynamics.timescales import J2000_UTC, utc_to_tt_seconds

ARCSEC = math.pi / (180.0 * 3600.0)

# IAU 1980 nutation, largest terms: multipliers of (l, l', F, D, Omega); dpsi = (A + A' T) sin arg,
# deps = (B + B' T) cos arg, in units of 0.0001".
NUTATION_1980 = (
    ((0, 0, 0, 0, 1), -171996.0, -174.2, 92025.0, 8.9),
    ((0, 0, 2, -2, 2), -13187.0, -1.6, 5736.0, -3.1),
    ((0, 0, 2, 0, 2), -2274.0, -0.2, 977.0, -0.5),
    ((0, 0, 0, 0, 2), 2062.0, 0.2, -895.0, 0.5),
    ((0, 1, 0, 0, 0), 1426.0, -3.4, 54.0, -0.1),
    ((1, 0, 0, 0, 0), 712.0, 0.1, -7.0, 0.0),
    ((0, 1, 2, -2, 2), -517.0, 1.2, 224.0, -0.6),
    ((0, 0, 2, 0, 1), -386.0, -0.4, 200.0, 0.0),
    ((1, 0, 2, 0, 2), -301.0, 0.0, 129.0, -0.1),
    ((0, -1, 2, -2, 2), 217.0, -0.5, -95.0, 0.3),
    ((1, 0, 0, -2, 0), -158.0, 0.0, -1.0, 0.0),
    ((0, 0, 2, -2, 1), 129.0, 0.1, -70.0, 0.0),
    ((-1, 0, 2, 0, 2), 123.0, 0.0, -53.0, 0.0),
)

_EOP = None


def _eop_table():
    """(MJD (n,), UT1 - UTC s (n,)) from finals2000A.all (rows without a value are skipped)."""
    global _EOP
    if _EOP is None:
        import skyfield_data

        path = os.path.join(os.path.dirname(skyfield_data.__file__), "data", "finals2000A.all")
        mjd, dut1 = [], []
        with open(path, encoding="ascii") as handle:
            for line in handle:
                value = line[58:68].strip()
                if value:
                    mjd.append(float(line[7:15]))
                    dut1.append(float(value))
        _EOP = (np.array(mjd), np.array(dut1))
    return _EOP


def ut1_minus_utc_s(moment: datetime) -> float:
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    mjd_table, dut1 = _eop_table()
    mjd = (moment - J2000_UTC).total_seconds() / 86400.0 + 51544.5
    if not mjd_table[0] <= mjd <= mjd_table[-1]:
        raise ValueError(f"{moment:%Y-%m-%d}: outside the IERS table ({mjd_table[0]:.0f}-{mjd_table[-1]:.0f} MJD)")
    # Linear between daily values, except across a leap second, where UT1 - UTC jumps by 1 s.
    i = int(np.searchsorted(mjd_table, mjd, side="right")) - 1
    i = min(i, mjd_table.size - 2)
    lo, hi = dut1[i], dut1[i + 1]
    if hi - lo > 0.5:
        hi -= 1.0
    frac = (mjd - mjd_table[i]) / (mjd_table[i + 1] - mjd_table[i])
    return float(lo + frac * (hi - lo))


def _rot(axis: int, angles):
    """Stacked frame rotations (m, 3, 3) about x (1), y (2) or z (3) by angles (m,) rad."""
    c, s = np.cos(angles), np.sin(angles)
    out = np.zeros((len(angles), 3, 3))
    i, j = {1: (1, 2), 2: (2, 0), 3: (0, 1)}[axis]
    k = 3 - i - j
    out[:, k, k] = 1.0
    out[:, i, i] = c
    out[:, j, j] = c
    out[:, i, j] = s
    out[:, j, i] = -s
    return out


def _fundamental_arguments(t):
    """Delaunay arguments l, l', F, D, Omega (rad) at TT Julian centuries t (m,) past J2000."""
    deg = (
        134.96340251 + (1717915923.2178 * t + 31.8792 * t**2) / 3600.0,
        357.52910918 + (129596581.0481 * t - 0.5532 * t**2) / 3600.0,
        93.27209062 + (1739527262.8478 * t - 12.7512 * t**2) / 3600.0,
        297.85019547 + (1602961601.2090 * t - 6.3706 * t**2) / 3600.0,
        125.04455501 + (-6962890.5431 * t + 7.4722 * t**2) / 3600.0,
    )
    return [np.radians(np.mod(d, 360.0)) for d in deg]


def nutation(t):
    """(dpsi, deps, mean obliquity) in rad at TT centuries t (scalar or (m,))."""
    t = np.asarray(t, dtype=float)
    args = _fundamental_arguments(t)
    dpsi = np.zeros_like(t)
    deps = np.zeros_like(t)
    for mult, a, a1, b, b1 in NUTATION_1980:
        arg = sum(m * x for m, x in zip(mult, args))
        dpsi = dpsi + (a + a1 * t) * np.sin(arg)
        deps = deps + (b + b1 * t) * np.cos(arg)
    eps0 = (84381.448 - 46.8150 * t - 0.00059 * t**2 + 0.001813 * t**3) * ARCSEC
    return dpsi * 1e-4 * ARCSEC, deps * 1e-4 * ARCSEC, eps0


def _rotations(t, tu):
    """ITRF -> GCRF (m, 3, 3) at TT centuries t (m,) and UT1 centuries tu (m,) past J2000."""
    zeta = (2306.2181 * t + 0.30188 * t**2 + 0.017998 * t**3) * ARCSEC
    z = (2306.2181 * t + 1.09468 * t**2 + 0.018203 * t**3) * ARCSEC
    theta = (2004.3109 * t - 0.42665 * t**2 - 0.041833 * t**3) * ARCSEC
    precession = _rot(3, -z) @ _rot(2, theta) @ _rot(3, -zeta)  # J2000 -> mean of date
    dpsi, deps, eps0 = nutation(t)
    nut = _rot(1, -(eps0 + deps)) @ _rot(3, -dpsi) @ _rot(1, eps0)  # mean of date -> true of date
    gmst_s = 67310.54841 + (876600.0 * 3600.0 + 8640184.812866) * tu + 0.093104 * tu**2 - 6.2e-6 * tu**3
    gast = np.radians(np.mod(gmst_s, 86400.0) / 240.0) + dpsi * np.cos(eps0 + deps)
    return np.transpose(precession, (0, 2, 1)) @ np.transpose(nut, (0, 2, 1)) @ _rot(3, -gast)


def itrf_to_gcrf_many(moments) -> np.ndarray:
    """The rotations (m, 3, 3) from the Earth-fixed frame to GCRF at UTC moments (see module docstring)."""
    moments = [m if m.tzinfo is not None else m.replace(tzinfo=timezone.utc) for m in moments]
    t = np.array([utc_to_tt_seconds(m) for m in moments]) / (86400.0 * 36525.0)
    tu = np.array([(m - J2000_UTC).total_seconds() + ut1_minus_utc_s(m) for m in moments]) / (86400.0 * 36525.0)
    return _rotations(t, tu)


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

