"""Hyperbolic Earth departures from the launch targets C3, DLA and RLA (003's departing spacecraft).

The departure hyperbola is fixed by:
- C3 (km^2/s^2): twice the orbital energy, v_inf^2; must be positive (a bound orbit has no asymptote);
- DLA / RLA (deg): declination and right ascension of the outgoing asymptote, ICRF (EME2000) axes;
- the periapsis radius (the parking orbit's, the injection taken as impulsive at periapsis);
- the plane through the asymptote: the one whose inclination to the equator is the parking orbit's
  (a launch site's latitude bounds it below; two planes qualify and `branch` picks one, +1 ascending);
- the time from periapsis of the wanted state.

Geometry (Vallado §12; Kizner): with e = 1 + r_p C3 / GM, the asymptote makes the angle
nu_inf = arccos(-1/e) with the periapsis in the orbit plane, so P = cos(nu_inf) S - sin(nu_inf) (h x S).
Hyperbolic Kepler's equation e sinh F - F = n t is solved by Newton's method.
"""

import numpy as np

from liaison_cli.dynamics.constants import DE421_GM_KM3_S2

GM_EARTH_KM3_S2 = DE421_GM_KM3_S2[399]  # the dated model's Earth (dynamics.constants)
# Where the departure model holds: the state is a two-body hyperbola from periapsis (no Moon, Sun or SRP).
# Against the same periapsis state flown in the full DE421 model, the three 003 missions' hyperbolas are off
# by at most 0.33 km and 0.08 m/s after 3 h (within 003's 1 km / 10 m/s a priori), but by 2.4 km after
# 6 h, 116 km after a day and ~10^8 km after a year. A scenario may start from injection to 3 h after it.
MAX_TIME_FROM_PERIAPSIS_S = 3 * 3600.0


def asymptote_unit(dla_deg: float, rla_deg: float) -> np.ndarray:
    dla, rla = np.radians(dla_deg), np.radians(rla_deg)
    return np.array([np.cos(dla) * np.cos(rla), np.cos(dla) * np.sin(rla), np.sin(dla)])


def asymptote_angles_deg(v_inf_km_s) -> tuple[float, float, float]:
    """(C3 km^2/s^2, DLA deg, RLA deg in [0, 360)) of an excess-velocity vector."""
    v = np.asarray(v_inf_km_s, dtype=float)
    speed = np.linalg.norm(v)
    return float(speed**2), float(np.degrees(np.arcsin(v[2] / speed))), float(np.degrees(np.arctan2(v[1], v[0])) % 360)


def _orbit_normal(s_hat, inclination_deg: float, branch: int) -> np.ndarray:
    """Unit normal h perpendicular to the asymptote with h . z = cos(inclination)."""
    cos_dla = np.sqrt(max(1.0 - s_hat[2] ** 2, 0.0))
    alpha = np.cos(np.radians(inclination_deg)) / cos_dla
    if alpha > 1.0 + 1e-12:
        raise ValueError(f"a plane of inclination {inclination_deg:g} deg cannot contain an asymptote at "
                         f"declination {np.degrees(np.arcsin(s_hat[2])):.3f} deg (need inclination >= |DLA|)")
    alpha = min(alpha, 1.0)
    n0 = (np.array([0.0, 0.0, 1.0]) - s_hat[2] * s_hat) / cos_dla
    return alpha * n0 + branch * np.sqrt(1.0 - alpha**2) * np.cross(s_hat, n0)


def _hyperbolic_anomaly(mean_anomaly: float, e: float) -> float:
    f = np.arcsinh(mean_anomaly / e)
    for _ in range(100):
        step = (e * np.sinh(f) - f - mean_anomaly) / (e * np.cosh(f) - 1.0)
        f -= step
        if abs(step) < 1e-15 * max(1.0, abs(f)):
            break
    return f


def departure_state_km(c3_km2_s2: float, dla_deg: float, rla_deg: float, periapsis_radius_km: float,
                       time_from_periapsis_s: float, inclination_deg: float, branch: int = 1,
                       gm_km3_s2: float = GM_EARTH_KM3_S2) -> np.ndarray:
    """Geocentric ICRF state (6,) km, km/s on the departure hyperbola, time_from_periapsis_s after periapsis."""
    if c3_km2_s2 <= 0.0:
        raise ValueError(f"C3 = {c3_km2_s2:g} km^2/s^2 is not a departure (needs C3 > 0)")
    s_hat = asymptote_unit(dla_deg, rla_deg)
    h_hat = _orbit_normal(s_hat, inclination_deg, branch)
    e = 1.0 + periapsis_radius_km * c3_km2_s2 / gm_km3_s2
    nu_inf = np.arccos(-1.0 / e)
    p_hat = np.cos(nu_inf) * s_hat - np.sin(nu_inf) * np.cross(h_hat, s_hat)
    q_hat = np.cross(h_hat, p_hat)
    a_km = -gm_km3_s2 / c3_km2_s2
    f = _hyperbolic_anomaly(np.sqrt(gm_km3_s2 / (-a_km) ** 3) * time_from_periapsis_s, e)
    nu = 2.0 * np.arctan(np.sqrt((e + 1.0) / (e - 1.0)) * np.tanh(0.5 * f))
    p_km = a_km * (1.0 - e * e)
    r_km = p_km / (1.0 + e * np.cos(nu))
    position = r_km * (np.cos(nu) * p_hat + np.sin(nu) * q_hat)
    velocity = np.sqrt(gm_km3_s2 / p_km) * (-np.sin(nu) * p_hat + (e + np.cos(nu)) * q_hat)
    return np.concatenate([position, velocity])
