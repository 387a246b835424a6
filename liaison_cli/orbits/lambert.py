"""Lambert's problem, single revolution, by universal variables (Bate, Mueller & White §5.3).

Given two positions and the flight time between them about one central body, find the conic's end
velocities. The time of flight is monotonic in the universal variable z = alpha * chi^2 for a single
revolution, so z is found by bracketing and bisection refined with Brent's method — slower than Newton on
z but it cannot diverge, and each solve costs well under a millisecond. Units: km, s, km^3/s^2.
"""

import numpy as np
from scipy.optimize import brentq


def stumpff_c(z: float) -> float:
    if z > 1e-8:
        return (1.0 - np.cos(np.sqrt(z))) / z
    if z < -1e-8:
        return (np.cosh(np.sqrt(-z)) - 1.0) / (-z)
    return 0.5 - z / 24.0 + z * z / 720.0


def stumpff_s(z: float) -> float:
    if z > 1e-8:
        sz = np.sqrt(z)
        return (sz - np.sin(sz)) / sz**3
    if z < -1e-8:
        sz = np.sqrt(-z)
        return (np.sinh(sz) - sz) / sz**3
    return 1.0 / 6.0 - z / 120.0 + z * z / 5040.0


def lambert(r1_km, r2_km, tof_s: float, gm_km3_s2: float, prograde_normal=(0.0, 0.0, 1.0)):
    """Velocities (v1, v2) (3,) km/s of the single-revolution conic from r1 to r2 in tof_s.

    The transfer turns the short or the long way so that its angular momentum points along
    `prograde_normal` (e.g. the ecliptic pole for a heliocentric transfer)."""
    r1, r2 = np.asarray(r1_km, dtype=float), np.asarray(r2_km, dtype=float)
    n1, n2 = np.linalg.norm(r1), np.linalg.norm(r2)
    cos_dnu = np.clip(r1 @ r2 / (n1 * n2), -1.0, 1.0)
    dnu = np.arccos(cos_dnu)
    if np.cross(r1, r2) @ np.asarray(prograde_normal, dtype=float) < 0.0:
        dnu = 2.0 * np.pi - dnu
    a_geo = np.sin(dnu) * np.sqrt(n1 * n2 / (1.0 - cos_dnu))

    def y_of(z):
        return n1 + n2 + a_geo * (z * stumpff_s(z) - 1.0) / np.sqrt(stumpff_c(z))

    def tof_of(z):
        y = y_of(z)
        chi = np.sqrt(y / stumpff_c(z))
        return (chi**3 * stumpff_s(z) + a_geo * np.sqrt(y)) / np.sqrt(gm_km3_s2)

    z_hi = (2.0 * np.pi) ** 2 * (1.0 - 1e-6)  # single revolution (C(z) stays representable)
    z_lo = -4.0 * np.pi**2
    if y_of(z_lo) < 0.0:  # y must stay positive: start where it turns positive (the flight time is ~0 there)
        z_lo = brentq(y_of, z_lo, z_hi, xtol=1e-14) + 1e-9
    while tof_of(z_lo) > tof_s:  # more hyperbolic
        z_lo -= 4.0 * np.pi**2
    z = brentq(lambda q: tof_of(q) - tof_s, z_lo, z_hi, xtol=1e-14, rtol=1e-14, maxiter=500)
    y = y_of(z)
    f = 1.0 - y / n1
    g = a_geo * np.sqrt(y / gm_km3_s2)
    g_dot = 1.0 - y / n2
    return (r2 - f * r1) / g, (g_dot * r2 - r1) / g
