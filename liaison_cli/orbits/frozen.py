"""Elliptical frozen lunar orbits (ELFOs): the eccentricity or the inclination at which an orbit's argument of
perilune stands still, so its perilune stays over one latitude for months (the orbits of LunaNet / Moonlight
relay designs, e.g. NASA's LCRNS reference constellation).

Model: the secular (orbit-averaged) rate of the argument of perilune omega of a Moon-centred orbit of semi-major
axis a, eccentricity e and inclination i to the Earth-Moon orbit plane, under the Moon's J2 and the Earth's tide
to quadrupole order, the Earth on a circle of radius d (the CRTBP's Earth):

    d omega/dt = 3/4 n J2 (R/p)^2 (5 cos^2 i - 1)                                      (the Moon's J2)
               + 3/4 (n_E^2 / n) [2 (1 - e^2) + 5 sin^2 omega (e^2 - sin^2 i)] / sqrt(1 - e^2)  (the Earth's tide)

with n = sqrt(GM_moon / a^3), p = a (1 - e^2), n_E^2 = GM_earth / d^3 (the quadrupole Kozai-Lidov rate of a test
particle, e.g. Naoz 2016, Annu. Rev. Astron. Astrophys. 54, in its test-particle limit). With omega at
90 or 270 degrees, de/dt and di/dt vanish (both go with sin 2 omega), and the orbit is frozen where d omega/dt =
0, i.e. where 2 + 3 e^2 - 5 sin^2 i + (J2 part) = 0.

That first-order average is only the start: near a frozen orbit its tide terms nearly cancel, so the terms it
drops (of order the month's rate over the orbit's, about 2 %) move the frozen inclination by about 1 degree
(measured: an orbit of a = 6,142 km, e = 0.6 frozen by the average turns its perilune by 0.03 deg/day in the
CRTBP). So `frozen_elements` then solves the CRTBP itself: it flies the orbit with the Moon's J2 (dynamics.
crtbp_field's TERM_J2) over one sidereal month, takes the perilune's mean turn between the first and the last
revolution, and moves the free element (secant) until that turn vanishes. Left out: the Moon's higher harmonics
(C22 averages out over the Moon's turn; a truth of higher degree perturbs the orbit it flies, which the run
shows), the Earth's orbital eccentricity and the Sun. tests/unit/orbits/test_frozen.py flies a solved orbit for
two months against orbits 3 degrees off it.
"""

import math
from functools import lru_cache

import numpy as np

from liaison_cli.dynamics.constants import GM_EARTH_KM3_S2, GM_MOON_KM3_S2, LU_KM, MOON_RADIUS_KM, MU, TU_S, VU_KM_S


def omega_rate_rad_s(a_km: float, e: float, i_deg: float, j2: float, radius_km: float, argp_deg: float = 90.0,
                     gm_moon=GM_MOON_KM3_S2, gm_earth=GM_EARTH_KM3_S2, earth_distance_km=LU_KM) -> float:
    """The secular d omega / dt (rad/s) of the module docstring."""
    n = math.sqrt(gm_moon / a_km**3)
    p = a_km * (1.0 - e * e)
    cos_i2, sin_i2 = math.cos(math.radians(i_deg)) ** 2, math.sin(math.radians(i_deg)) ** 2
    sin_w2 = math.sin(math.radians(argp_deg)) ** 2
    moon = 0.75 * n * j2 * (radius_km / p) ** 2 * (5.0 * cos_i2 - 1.0)
    tide = (0.75 * gm_earth / earth_distance_km**3 / n * (2.0 * (1.0 - e * e) + 5.0 * sin_w2 * (e * e - sin_i2))
            / math.sqrt(1.0 - e * e))
    return moon + tide


class NoFrozenOrbit(ValueError):
    """No frozen orbit with the elements given (the message says which and why)."""


def frozen_inclination_deg(a_km: float, e: float, j2: float, radius_km: float) -> float:
    """The prograde inclination (deg, 0..90) at which an orbit of (a_km, e) with omega = 90 / 270 deg is frozen."""
    from scipy.optimize import brentq  # here: `liaison run` does not load scipy.optimize (tests/test_architecture.py)

    def rate(i_deg):
        return omega_rate_rad_s(a_km, e, i_deg, j2, radius_km)

    if rate(0.0) * rate(90.0) > 0.0:
        raise NoFrozenOrbit(f"no inclination freezes a = {a_km:.0f} km, e = {e:g}: omega turns the same way at "
                            "every inclination")
    return float(brentq(rate, 0.0, 90.0, xtol=1e-12))


def frozen_eccentricity(i_deg: float, j2: float, radius_km: float, a_km: float | None = None,
                        perilune_altitude_km: float | None = None) -> float:
    """The eccentricity at which an orbit of inclination i_deg with omega = 90 / 270 deg is frozen, for a given
    semi-major axis or a given perilune altitude above the mean radius (then a = (R + h) / (1 - e))."""
    from scipy.optimize import brentq  # here: `liaison run` does not load scipy.optimize (tests/test_architecture.py)

    def a_of(e):
        return a_km if a_km is not None else (MOON_RADIUS_KM + perilune_altitude_km) / (1.0 - e)

    def rate(e):
        return omega_rate_rad_s(a_of(e), e, i_deg, j2, radius_km)

    top = 0.95
    if a_km is not None:  # the perilune must clear the surface
        top = min(top, 1.0 - MOON_RADIUS_KM / a_km - 1e-9)
    if top <= 0.0 or rate(0.0) * rate(top) > 0.0:
        size = f"a = {a_km:.0f} km" if a_km is not None else f"a perilune {perilune_altitude_km:g} km up"
        raise NoFrozenOrbit(f"no eccentricity up to {max(top, 0.0):.3g} freezes an orbit inclined {i_deg:g} deg with "
                            f"{size} under the Moon's J2 and the Earth's tide: the tide that freezes an orbit needs "
                            "it high (a of thousands of km) and inclined between 39.2 and 140.8 deg")
    return float(brentq(rate, 0.0, top, xtol=1e-13))


# The refinement's flight: RK8 steps of at most 60 s, 48 samples per revolution over the first and the last one.
_STEP_S, _SAMPLES_PER_REVOLUTION = 60.0, 48
# Stop when the perilune turns by less than this (deg/day): 0.1 deg a thousand days.
RATE_TOLERANCE_DEG_DAY = 1e-4


def flown_argp_rate_deg_day(a_km: float, e: float, i_deg: float, argp_deg: float, j2: float, radius_km: float,
                            raan_deg: float = 0.0) -> float:
    """The perilune's mean turn (deg/day) over one sidereal month (2 pi TU) of the orbit flown in the CRTBP with the
    Moon's J2: the mean argument of perilune over the last revolution minus over the first, over the time between."""
    from liaison_cli.dynamics.crtbp_field import crtbp_params, j2_term
    from liaison_cli.dynamics.integrators.rk8 import rk8_states_forced
    from liaison_cli.orbits.keplerian import lunar_orbiter_state_lu

    params = crtbp_params(MU, j2_term(j2, radius_km))
    period_tu = 2.0 * math.pi * math.sqrt(a_km**3 / GM_MOON_KM3_S2) / TU_S
    month_tu = 2.0 * math.pi
    first = np.linspace(0.0, period_tu, _SAMPLES_PER_REVOLUTION, endpoint=False)
    times = np.concatenate([first, month_tu - period_tu + first])
    x0 = lunar_orbiter_state_lu(a_km, e, i_deg, raan_deg, argp_deg, 0.0)
    states = rk8_states_forced(x0, times, _STEP_S / TU_S, params, np.zeros((len(times), 3)))
    argp = np.unwrap(np.radians(_arguments_of_perilune_deg(states, times)))
    turn = argp[_SAMPLES_PER_REVOLUTION:].mean() - argp[:_SAMPLES_PER_REVOLUTION].mean()
    return float(np.degrees(turn) / ((month_tu - period_tu) * TU_S / 86400.0))


def _arguments_of_perilune_deg(states, times_tu) -> np.ndarray:
    """Osculating Moon-centred arguments of perilune (deg) of rotating-frame states (m, 6) at times_tu."""
    out = np.empty(len(states))
    moon = np.array([1.0 - MU, 0.0, 0.0])
    for k, (state, t) in enumerate(zip(states, times_tu)):
        r_rot = state[:3] - moon
        v_rot = state[3:] + np.cross([0.0, 0.0, 1.0], r_rot)
        c, s = math.cos(t), math.sin(t)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        r, v = turn @ r_rot * LU_KM, turn @ v_rot * VU_KM_S
        h = np.cross(r, v)
        node = np.cross([0.0, 0.0, 1.0], h)
        ecc = np.cross(v, h) / GM_MOON_KM3_S2 - r / np.linalg.norm(r)
        cosine = np.dot(node, ecc) / (np.linalg.norm(node) * np.linalg.norm(ecc))
        angle = math.degrees(math.acos(max(-1.0, min(1.0, cosine))))
        out[k] = angle if ecc[2] >= 0.0 else 360.0 - angle
    return out


@lru_cache(maxsize=64)
def frozen_elements(j2: float, radius_km: float, argp_deg: float, e: float | None = None, i_deg: float | None = None,
                    a_km: float | None = None, perilune_altitude_km: float | None = None) -> tuple[float, float, float]:
    """(a_km, e, i_deg) of the frozen orbit (module docstring) with the elements given: e or i_deg, and a_km or the
    perilune's altitude; the first-order average's solution refined in the CRTBP with the Moon's J2 (secant on
    the free element until the flown turn is below RATE_TOLERANCE_DEG_DAY). Raises NoFrozenOrbit when the average
    has none."""
    def a_of(ecc):
        return a_km if a_km is not None else (MOON_RADIUS_KM + perilune_altitude_km) / (1.0 - ecc)

    if i_deg is None:
        def rate(x):
            return flown_argp_rate_deg_day(a_of(e), e, x, argp_deg, j2, radius_km)
        start, step = frozen_inclination_deg(a_of(e), e, j2, radius_km), 0.5
    else:
        def rate(x):
            return flown_argp_rate_deg_day(a_of(x), x, i_deg, argp_deg, j2, radius_km)
        start = frozen_eccentricity(i_deg, j2, radius_km, a_km, perilune_altitude_km)
        step = 0.01
    x0, x1 = start, start + step
    r0, r1 = rate(x0), rate(x1)
    for _ in range(12):
        if not (math.isfinite(r0) and math.isfinite(r1)) or abs(r1) < RATE_TOLERANCE_DEG_DAY or r1 == r0:
            break
        x0, x1, r0 = x1, x1 - r1 * (x1 - x0) / (r1 - r0), r1
        r1 = rate(x1)
    if not abs(r1) < RATE_TOLERANCE_DEG_DAY:  # NaN too: a flight that failed (a perilune inside the Moon)
        raise NoFrozenOrbit(f"the CRTBP's frozen orbit near the average's ({start:.4g}) was not found: the perilune "
                            f"still turns {r1:.2g} deg/day")
    ecc = e if i_deg is None else x1
    return a_of(ecc), ecc, (x1 if i_deg is None else i_deg)
