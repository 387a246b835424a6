"""The Moon's orientation for the dated model: the rotation from the ICRF to the lunar principal axes (PA), the
frame GRGM1200A's coefficients are given in (dynamics.lunar_gravity).

Two parts, composed:
1. ICRF -> mean Earth / polar axis (ME): the IAU WGCCRE model of the Moon (Archinal et al. 2011, Celestial
   Mechanics and Dynamical Astronomy 109, Table 2; unchanged in the 2015 report): the pole's right ascension
   alpha0 and declination delta0 and the prime meridian W, each a polynomial in time plus the series in the 13
   arguments E1..E13 (IAU_MOON_SERIES, data). Then r_ME = Rz(W) Rx(90 deg - delta0) Rz(90 deg + alpha0) r_ICRF,
   with R_i(angle) the rotation of the axes (a passive rotation) about axis i.
2. ME -> PA: the constant rotation of DE430's lunar frames (Williams et al. 2013, "DE430 Lunar Orbit, Physical
   Librations, and Surface Coordinates"; the frame GRGM1200A is referred to): r_ME = Rx(-0.285") Ry(-78.580")
   Rz(-67.573") r_PA, about 0.8 km at the lunar surface.

What it leaves out: the IAU series is a fit to an older ephemeris's librations, not a DE's numerically integrated
ones. Against DE421's (the ephemeris whose bodies the dated model flies; the `de421` package, a test dependency)
these axes are within 18.1" at worst over 2000-2049 (153 m at the surface), 9.4" RMS, which moves the degree-100
field at 100 km by 0.04 % of its RMS (benchmarks.lunar_orientation; tests/unit/dynamics/test_lunar_orientation.py).

Time: TDB seconds past J2000 (the dated model's). d = days, T = Julian centuries past J2000.
"""

import math

import numpy as np
from numba import njit

ARCSEC = math.pi / (180.0 * 3600.0)
# ME -> PA of DE430 (module docstring): the three angles of r_ME = Rx(-c) Ry(-b) Rz(-a) r_PA, arcseconds.
DE430_PA_TO_ME_ARCSEC = (67.573, 78.580, 0.285)

# IAU series (Archinal et al. 2011, Table 2): argument k is E_k = constant + rate * d (deg, deg/day); the pole and
# the prime meridian add amplitude * sin (alpha0, W) or * cos (delta0) of E_k (deg).
#                     E constant, E rate,      alpha0 sin, delta0 cos, W sin
IAU_MOON_SERIES = np.array([
    [125.045, -0.0529921, -3.8787, 1.5419, 3.5610],
    [250.089, -0.1059842, -0.1204, 0.0239, 0.1208],
    [260.008, 13.0120009, 0.0700, -0.0278, -0.0642],
    [176.625, 13.3407154, -0.0172, 0.0068, 0.0158],
    [357.529, 0.9856003, 0.0, 0.0, 0.0252],
    [311.589, 26.4057084, 0.0072, -0.0029, -0.0066],
    [134.963, 13.0649930, 0.0, 0.0009, -0.0047],
    [276.617, 0.3287146, 0.0, 0.0, -0.0046],
    [34.226, 1.7484877, 0.0, 0.0, 0.0028],
    [15.134, -0.1589763, -0.0052, 0.0008, 0.0052],
    [119.743, 0.0036096, 0.0, 0.0, 0.0040],
    [239.961, 0.1643573, 0.0, 0.0, 0.0019],
    [25.053, 12.9590088, 0.0043, -0.0009, -0.0044],
])
# The polynomial parts (deg; per Julian century for the pole, per day and day^2 for W).
ALPHA0_DEG, ALPHA0_RATE_DEG_CY = 269.9949, 0.0031
DELTA0_DEG, DELTA0_RATE_DEG_CY = 66.5392, 0.0130
W_DEG, W_RATE_DEG_DAY, W_ACCEL_DEG_DAY2 = 38.3213, 13.17635815, -1.4e-12


def _axes_rotation(axis: int, angle_rad: float) -> np.ndarray:
    """The passive rotation R_axis(angle): the components of a fixed vector in axes turned by +angle."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.eye(3)
    out[i, i], out[i, j], out[j, i], out[j, j] = c, s, -s, c
    return out


def _pa_from_me() -> np.ndarray:
    a, b, c = (value * ARCSEC for value in DE430_PA_TO_ME_ARCSEC)
    me_from_pa = _axes_rotation(0, -c) @ _axes_rotation(1, -b) @ _axes_rotation(2, -a)
    return me_from_pa.T.copy()


PA_FROM_ME = _pa_from_me()


@njit(cache=True)
def iau_moon_angles_deg(t_tdb_s):
    """(alpha0, delta0, W) of the IAU model at TDB seconds past J2000, degrees (W not reduced modulo 360)."""
    d = t_tdb_s / 86400.0
    centuries = d / 36525.0
    alpha = ALPHA0_DEG + ALPHA0_RATE_DEG_CY * centuries
    delta = DELTA0_DEG + DELTA0_RATE_DEG_CY * centuries
    w = W_DEG + W_RATE_DEG_DAY * d + W_ACCEL_DEG_DAY2 * d * d
    for k in range(IAU_MOON_SERIES.shape[0]):
        e = math.radians(IAU_MOON_SERIES[k, 0] + IAU_MOON_SERIES[k, 1] * d)
        sin_e = math.sin(e)
        alpha += IAU_MOON_SERIES[k, 2] * sin_e
        delta += IAU_MOON_SERIES[k, 3] * math.cos(e)
        w += IAU_MOON_SERIES[k, 4] * sin_e
    return alpha, delta, w


@njit(cache=True)
def moon_pa_from_icrf_into(t_tdb_s, out):
    """out (3, 3) <- the rotation r_PA = out @ r_ICRF at TDB seconds past J2000 (module docstring)."""
    alpha, delta, w = iau_moon_angles_deg(t_tdb_s)
    # ME from ICRF = Rz(W) Rx(90 - delta) Rz(90 + alpha), written out: the rows are the ME axes in the ICRF.
    a, dd, ww = math.radians(90.0 + alpha), math.radians(90.0 - delta), math.radians(w)
    ca, sa, cd, sd, cw, sw = math.cos(a), math.sin(a), math.cos(dd), math.sin(dd), math.cos(ww), math.sin(ww)
    me = np.empty((3, 3))
    me[0, 0], me[0, 1], me[0, 2] = cw * ca - sw * cd * sa, cw * sa + sw * cd * ca, sw * sd
    me[1, 0], me[1, 1], me[1, 2] = -sw * ca - cw * cd * sa, -sw * sa + cw * cd * ca, cw * sd
    me[2, 0], me[2, 1], me[2, 2] = sd * sa, -sd * ca, cd
    for i in range(3):
        for j in range(3):
            out[i, j] = PA_FROM_ME[i, 0] * me[0, j] + PA_FROM_ME[i, 1] * me[1, j] + PA_FROM_ME[i, 2] * me[2, j]


def moon_pa_from_icrf(t_tdb_s: float) -> np.ndarray:
    """(3, 3): r_PA = R @ r_ICRF at TDB seconds past J2000."""
    out = np.empty((3, 3))
    moon_pa_from_icrf_into(float(t_tdb_s), out)
    return out
