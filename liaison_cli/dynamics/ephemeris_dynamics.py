"""Dated dynamics (003 §"Dynamical model"): a geocentric ICRF point-mass field from DE421 plus cannonball
solar radiation pressure with Earth and Moon shadows, and its variational equations.

  r'' = -GM_E r / r^3 + sum_b GM_b ((r_b - r) / |r_b - r|^3 - r_b / r_b^3) + nu C_R (A/m) P(d) d / |d|
with d = r - r_sun and P(d) = P_1AU (1 AU / |d|)^2 (003 Eq. 4-5). Shadow: the conical model (Montenbruck &
Gill 2000, §3.4.2): the visible fraction nu of the solar disc behind the Earth and behind the Moon, with
their radii, so nu = 0 in umbra, 1 in sunlight and continuous across the penumbra (the two occulters'
fractions multiply). Variational equations: the gravity gradients of every body and of the SRP term with
nu held constant (its derivative is non-zero only in penumbra, minutes per eclipse).

Here: the right-hand side (`ephemeris_derivative`), the shadow (`visible_fraction`, `shadow_edges`) and the
truth (`dop853_ephemeris_states`: integrators.adaptive's DOP853, restarted at every shadow edge). The filter's
fixed-step RK8 of this field is integrators.rk8.rk8_advance_ephemeris.

Units: km, km/s, TDB seconds past J2000. Bodies come as codes of dynamics.ephemeris with their GM.
"""

import math

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import (
    AU_KM, EARTH_SHADOW_RADIUS_KM, MOON_RADIUS_KM, SOLAR_FLUX_1AU_W_M2, SPEED_OF_LIGHT_M_S, SUN_RADIUS_KM)
from liaison_cli.dynamics.ephemeris import BODY_EARTH, BODY_MOON, BODY_SUN, geocentric_state
from liaison_cli.dynamics.integrators.adaptive import dop853_samples

P_1AU_N_M2 = SOLAR_FLUX_1AU_W_M2 / SPEED_OF_LIGHT_M_S
# Lengths of the integrated vector: the state and its STM (6 + 36), and with the C_R sensitivity column (+ 6).
STM_SIZE = 42
SENSITIVITY_SIZE = 48
# The shadow's occulters and the Sun's disc, by their short names here.
R_SUN_KM, R_EARTH_KM, R_MOON_KM = SUN_RADIUS_KM, EARTH_SHADOW_RADIUS_KM, MOON_RADIUS_KM


@njit(cache=True)
def visible_fraction(r_sat, r_sun, r_body, radius_body):
    """Conical shadow: the fraction of the solar disc seen from r_sat past a spherical body (all geocentric
    km). 1 in sunlight, 0 in umbra, 1 - (b/a)^2 in annular eclipse, the overlap area in penumbra."""
    ds = r_sun - r_sat
    db = r_body - r_sat
    ns = math.sqrt(ds[0] ** 2 + ds[1] ** 2 + ds[2] ** 2)
    nb = math.sqrt(db[0] ** 2 + db[1] ** 2 + db[2] ** 2)
    if nb <= radius_body:
        return 0.0  # inside the body: no sunlight
    a = math.asin(min(R_SUN_KM / ns, 1.0))
    b = math.asin(min(radius_body / nb, 1.0))
    cos_c = (ds[0] * db[0] + ds[1] * db[1] + ds[2] * db[2]) / (ns * nb)
    c = math.acos(max(-1.0, min(1.0, cos_c)))
    if c >= a + b:
        return 1.0
    if c <= b - a:
        return 0.0
    if c <= a - b:
        return 1.0 - (b * b) / (a * a)
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = math.sqrt(max(a * a - x * x, 0.0))
    area = a * a * math.acos(max(-1.0, min(1.0, x / a))) + b * b * math.acos(max(-1.0, min(1.0, (c - x) / b))) - c * y
    return 1.0 - area / (math.pi * a * a)


@njit(cache=True)
def srp_acceleration(r_sat, r_sun, r_moon, cr_area_over_mass_m2_kg, out):
    """SRP acceleration (km/s^2) into out (3,); returns nu. cr_area_over_mass: C_R A/m in m^2/kg."""
    nu = visible_fraction(r_sat, r_sun, np.zeros(3), R_EARTH_KM) * visible_fraction(r_sat, r_sun, r_moon, R_MOON_KM)
    d0, d1, d2 = r_sat[0] - r_sun[0], r_sat[1] - r_sun[1], r_sat[2] - r_sun[2]
    dn = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    # P(d) C_R A/m in m/s^2, times 1e-3 for km/s^2, along the unit vector from the Sun.
    k = nu * P_1AU_N_M2 * (AU_KM / dn) ** 2 * cr_area_over_mass_m2_kg * 1e-3 / dn
    out[0] = k * d0
    out[1] = k * d1
    out[2] = k * d2
    return nu


@njit(cache=True)
def _point_mass(out_a, grad, r, r_b, gm, indirect, with_grad):
    """Adds GM ((r_b - r)/|r_b - r|^3 - indirect * r_b/|r_b|^3) and its gradient w.r.t. r."""
    d0, d1, d2 = r[0] - r_b[0], r[1] - r_b[1], r[2] - r_b[2]
    d2n = d0 * d0 + d1 * d1 + d2 * d2
    dn = math.sqrt(d2n)
    k = gm / (d2n * dn)
    out_a[0] -= k * d0
    out_a[1] -= k * d1
    out_a[2] -= k * d2
    if indirect:
        b2 = r_b[0] ** 2 + r_b[1] ** 2 + r_b[2] ** 2
        kb = gm / (b2 * math.sqrt(b2))
        for i in range(3):
            out_a[i] -= kb * r_b[i]
    if with_grad:
        d = (d0, d1, d2)
        c = 3.0 * k / d2n
        for i in range(3):
            for j in range(3):
                grad[i, j] += c * d[i] * d[j] - (k if i == j else 0.0)


@njit(cache=True)
def ephemeris_derivative(t_s, y, coeffs, start_s, interval_s, n_records, bodies, gms, gm_earth, cr_am, with_stm, out):
    """dy/dt for y = [r, v] (6,), [r, v, Phi row-major] (42,) or [r, v, Phi, s] (48,), geocentric ICRF km, km/s
    at TDB t_s. bodies / gms (B,): third bodies (codes of dynamics.ephemeris) and their GM; cr_am: C_R A/m
    (m^2/kg), 0 for no SRP (the Sun must then still be in `bodies` for its gravity).

    s (6,) = dx/dlambda, the state's sensitivity to a relative change of C_R (C_R -> C_R (1 + lambda) at
    lambda = 0): s' = A s + [0; a_srp], since the SRP acceleration is linear in C_R (Tapley, Schutz & Born
    2004, §4.2.1, the variational equations of a dynamic parameter)."""
    r = y[0:3]
    acc = np.zeros(3)
    grad = np.zeros((3, 3))
    _point_mass(acc, grad, r, np.zeros(3), gm_earth, np.bool_(False), with_stm)  # no literal: one compile
    r_sun = np.zeros(3)
    r_moon = np.zeros(3)
    for i in range(bodies.shape[0]):
        state = geocentric_state(coeffs, start_s, interval_s, n_records, bodies[i], t_s)
        r_b = state[0:3].copy()
        _point_mass(acc, grad, r, r_b, gms[i], np.bool_(True), with_stm)
        if bodies[i] == BODY_SUN:
            r_sun = r_b
        elif bodies[i] == BODY_MOON:
            r_moon = r_b
    a_srp = np.zeros(3)
    if cr_am > 0.0:
        if r_moon[0] == 0.0 and r_moon[1] == 0.0 and r_moon[2] == 0.0:  # the Moon's shadow needs its position
            r_moon = geocentric_state(coeffs, start_s, interval_s, n_records, np.int64(BODY_MOON), t_s)[0:3].copy()
        nu = srp_acceleration(r, r_sun, r_moon, cr_am, a_srp)
        for i in range(3):
            acc[i] += a_srp[i]
        if with_stm and nu > 0.0:
            d = r - r_sun
            d2n = d[0] ** 2 + d[1] ** 2 + d[2] ** 2
            dn = math.sqrt(d2n)
            k = nu * P_1AU_N_M2 * AU_KM**2 * cr_am * 1e-3 / (d2n * dn)  # a = k d: gradient k (I - 3 d d^T / d^2)
            for i in range(3):
                for j in range(3):
                    grad[i, j] += k * ((1.0 if i == j else 0.0) - 3.0 * d[i] * d[j] / d2n)
    for i in range(3):
        out[i] = y[3 + i]
        out[3 + i] = acc[i]
    if with_stm:
        for j in range(6):  # Phi' = A Phi with A = [[0, I], [grad, 0]]
            for i in range(3):
                out[6 + 6 * i + j] = y[6 + 6 * (3 + i) + j]
                acc_ij = 0.0
                for l in range(3):
                    acc_ij += grad[i, l] * y[6 + 6 * l + j]
                out[6 + 6 * (3 + i) + j] = acc_ij
    if y.shape[0] == SENSITIVITY_SIZE:  # s' = A s + d(acc)/dlambda
        for i in range(3):
            out[STM_SIZE + i] = y[STM_SIZE + 3 + i]
            acc_i = a_srp[i]
            for l in range(3):
                acc_i += grad[i, l] * y[STM_SIZE + l]
            out[STM_SIZE + 3 + i] = acc_i


@njit(cache=True)
def shadow_edges(r_sat, r_sun, r_body, radius_body):
    """(c - (a + b), c - |a - b|): zero where the satellite enters or leaves the penumbra and the umbra (or
    annular zone) of a body; the conical model's nu has a kink at each, which the truth steps onto."""
    ds = r_sun - r_sat
    db = r_body - r_sat
    ns = math.sqrt(ds[0] ** 2 + ds[1] ** 2 + ds[2] ** 2)
    nb = math.sqrt(db[0] ** 2 + db[1] ** 2 + db[2] ** 2)
    a = math.asin(min(R_SUN_KM / ns, 1.0))
    b = math.asin(min(radius_body / nb, 1.0))
    c = math.acos(max(-1.0, min(1.0, (ds[0] * db[0] + ds[1] * db[1] + ds[2] * db[2]) / (ns * nb))))
    return c - (a + b), c - abs(a - b)


def dop853_ephemeris_states(x0, t0_s, times_s, window, bodies, gms, gm_earth, cr_am, rtol=1e-12, atol=1e-9,
                            acceleration_km_s2=None, acceleration_table_km_s2=None):
    """Truth states (m, 6) at times_s by scipy's adaptive DOP853 (integrators.adaptive.dop853_samples) on the
    compiled derivative, restarted at every shadow edge (penumbra and umbra of the Earth and the Moon, located
    as events): the conical shadow's kinks would otherwise cost metres after one eclipse (a fixed-step RK8 at
    864 s: 1.6 m after 9 days; DOP853 without the restarts: 0.6 m). Tolerances rtol 1e-12, atol 1e-9 km; after
    9 days with one eclipse this truth is within 2.3 cm of itself at rtol 1e-13
    (tests/unit/dynamics/test_ephemeris.py). acceleration_km_s2 (3,): a constant extra acceleration on the ICRF
    axes (the truth's unmodelled force; None: none); acceleration_table_km_s2 (m, 3): one more, given at
    times_s and linear between them (a Gauss-Markov force drawn per run; None: none)."""
    out = np.empty(6)
    args = (window.coeffs, window.start_s, window.interval_s, window.n_records)

    forced = acceleration_km_s2 is not None and np.any(np.asarray(acceleration_km_s2) != 0.0)
    table = None if acceleration_table_km_s2 is None else _LinearTable(times_s, acceleration_table_km_s2)

    def rhs(t, y):
        ephemeris_derivative(t, y, *args, bodies, gms, gm_earth, cr_am, False, out)
        rate = out.copy()
        if forced:
            rate[3:] += acceleration_km_s2
        if table is not None:
            rate[3:] += table(t)
        return rate

    def edge(which, body):
        def event(t, y):
            r_sun = geocentric_state(*args, np.int64(BODY_SUN), t)[0:3]
            r_body = np.zeros(3) if body == BODY_EARTH else geocentric_state(*args, np.int64(BODY_MOON), t)[0:3]
            return shadow_edges(y[0:3], r_sun, r_body, R_EARTH_KM if body == BODY_EARTH else R_MOON_KM)[which]

        event.terminal = True
        return event

    events = [edge(w, b) for w in (0, 1) for b in (BODY_EARTH, BODY_MOON)] if cr_am > 0.0 else []
    return dop853_samples(rhs, t0_s, x0, times_s, rtol, atol, events, what="ephemeris truth propagation")


class _LinearTable:
    """values (m, k) given at ascending times (m,), linear between them and held past either end."""

    def __init__(self, times, values):
        self.times, self.values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)

    def __call__(self, t: float) -> np.ndarray:
        i = min(max(int(np.searchsorted(self.times, t, side="right")) - 1, 0), len(self.times) - 2)
        fraction = min(max((t - self.times[i]) / (self.times[i + 1] - self.times[i]), 0.0), 1.0)
        return self.values[i] + (self.values[i + 1] - self.values[i]) * fraction
