"""Dated dynamics (003 §"Dynamical model"): a geocentric ICRF point-mass field from DE421 plus cannonball
solar radiation pressure with Earth and Moon shadows, and its variational equations.

  r'' = -GM_E r / r^3 + sum_b GM_b ((r_b - r) / |r_b - r|^3 - r_b / r_b^3) + nu C_R (A/m) P(d) d / |d|
with d = r - r_sun and P(d) = P_1AU (1 AU / |d|)^2 (003 Eq. 4-5). Shadow: the conical model (Montenbruck &
Gill 2000, §3.4.2): the visible fraction nu of the solar disc behind the Earth and behind the Moon, with
their radii, so nu = 0 in umbra, 1 in sunlight and continuous across the penumbra (the two occulters'
fractions multiply). Variational equations: the gravity gradients of every body and of the SRP term with
nu held constant (its derivative is non-zero only in penumbra, minutes per eclipse).

With a lunar field (the scenario's moon_gravity), the Moon's spherical harmonics beyond its point mass are added
(`add_moon_field`: GRGM1200A in the Moon's principal axes, turned by dynamics.lunar_orientation), with their
gradient in the variational equations.

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
from liaison_cli.dynamics.ephemeris import BODY_EARTH, BODY_MOON, BODY_SUN, geocentric_positions_into, geocentric_state
from liaison_cli.dynamics.integrators.adaptive import dop853_samples
from liaison_cli.dynamics.lunar_orientation import moon_pa_from_icrf_into
from liaison_cli.dynamics.spherical_harmonics import field_acceleration_into, field_payload, payload_tables
from liaison_cli.dynamics.zonal_j2 import j2_acceleration_gradient_into

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


# The forces beyond the bodies' point masses and SRP, as a table of terms (ephemeris_derivative's `terms`): [T, then T
# pairs (kind, start of its payload in the table), then the payloads]; NO_TERMS: none. A kind is a part: its payload
# (built by its own function) and its branch in add_terms_at_moon.
NO_TERMS = np.zeros(0)
TERM_MOON_HARMONICS = 1  # payload: moon_field_payload
TERM_MOON_J2 = 2  # payload: J2, reference radius (km): the Moon's J2 alone in closed form (dynamics.zonal_j2)


def dated_terms(*terms) -> np.ndarray:
    """The terms table of (kind, payload) pairs (None ones left out); NO_TERMS when there are none."""
    terms = [term for term in terms if term is not None]
    if not terms:
        return NO_TERMS
    table, payloads, start = [float(len(terms))], [], 1 + 2 * len(terms)
    for kind, payload in terms:
        table += [float(kind), float(start)]
        payloads.append(np.asarray(payload, dtype=float))
        start += len(payload)
    return np.concatenate([table, *payloads])


def term_of(terms, kind: int):
    """The payload of the first term of `kind` in a terms table (None when it has none)."""
    for t in range(int(terms[0]) if len(terms) else 0):
        if int(terms[1 + 2 * t]) == kind:
            return terms[int(terms[2 + 2 * t]):]
    return None


def moon_harmonics_term(field) -> tuple[int, np.ndarray] | None:
    """(TERM_MOON_HARMONICS, payload) of a dynamics.lunar_gravity.LunarField (None: none)."""
    return None if field is None else (TERM_MOON_HARMONICS, moon_field_payload(field))


def moon_j2_term(j2: float, radius_km: float) -> tuple[int, np.ndarray]:
    """(TERM_MOON_J2, payload): a J2 (unnormalised) and its reference radius, e.g. lunar_gravity.lunar_j2()'s."""
    return TERM_MOON_J2, np.array([j2, radius_km])


def moon_field_payload(field) -> np.ndarray:
    """The Moon's harmonics' payload for a dynamics.lunar_gravity.LunarField: spherical_harmonics.field_payload with
    the reference radius in km (the CRTBP's layout, its radius in LU)."""
    return field_payload(field.c, field.s, field.degree, field.radius_km)


# add_moon_field's and add_moon_j2's scratch (_frame_scratch): the rotation (9), the position in the principal axes
# (3), the acceleration (3) and gradient (6) there, and G_PA R (9).
FRAME_SCRATCH = 30


@njit(cache=True)
def add_moon_field(t_s, r, r_moon, gm_moon, field, with_grad, acc, grad):
    """acc (3,) += the Moon's harmonics beyond its point mass (payload `field`, moon_field_payload) at the geocentric
    ICRF position r (km), the Moon at r_moon, at TDB t_s; with with_grad, grad (3, 3) += their gradient. Evaluated
    in the lunar principal axes (dynamics.lunar_orientation) and turned back: a = R^T a_PA(R (r - r_moon)),
    G = R^T G_PA R. The Moon's GM is the model's (so a scaled Moon GM scales its field as well). Four allocations:
    the frame's scratch, the harmonics' two tables (as long as the point needs) and the orientation's own."""
    degree, radius, tables = payload_tables(field)
    rot, p, a_pa, g, turned = _frame_scratch(np.empty(FRAME_SCRATCH))
    _in_principal_axes_into(t_s, r, r_moon, rot, p)
    field_acceleration_into(tables, gm_moon, radius, degree, p[0], p[1], p[2], with_grad, a_pa, g)
    _add_turned_back(rot, a_pa, g, with_grad, acc, grad, turned)


@njit(cache=True)
def add_moon_j2(t_s, r, r_moon, gm_moon, payload, with_grad, acc, grad):
    """add_moon_field for the Moon's J2 alone (payload: J2, radius km), about the lunar pole (the principal axes' z;
    J2 is symmetric about it, so the other two axes do not matter)."""
    rot, p, a_pa, g, turned = _frame_scratch(np.empty(FRAME_SCRATCH))
    _in_principal_axes_into(t_s, r, r_moon, rot, p)
    j2_acceleration_gradient_into(gm_moon, payload[0], payload[1], p[0], p[1], p[2], with_grad, a_pa, g)
    _add_turned_back(rot, a_pa, g, with_grad, acc, grad, turned)


@njit(cache=True, inline="always")
def _frame_scratch(work):
    """(rot (3, 3), p (3,), a_pa (3,), g (6,), turned (3, 3)): views of work (FRAME_SCRATCH,)."""
    return work[0:9].reshape((3, 3)), work[9:12], work[12:15], work[15:21], work[21:30].reshape((3, 3))


@njit(cache=True)
def _in_principal_axes_into(t_s, r, r_moon, rot, p):
    """rot (3, 3) <- the ICRF -> lunar principal axes rotation at TDB t_s, p (3,) <- R (r - r_moon), km."""
    moon_pa_from_icrf_into(t_s, rot)
    for i in range(3):
        p[i] = 0.0
        for j in range(3):
            p[i] += rot[i, j] * (r[j] - r_moon[j])


@njit(cache=True)
def _add_turned_back(rot, a_pa, g, with_grad, acc, grad, turned):
    """acc += R^T a_pa; with with_grad, grad (3, 3) += R^T G R, G the symmetric gradient g (gxx, gyy, gzz, gxy, gxz,
    gyz) in the principal axes; turned (3, 3) scratch. G R in element loops, not a matrix product: numba's `@`
    calls BLAS's dgemm (a library call and an allocation for nine sums of three products)."""
    for j in range(3):
        acc[j] += rot[0, j] * a_pa[0] + rot[1, j] * a_pa[1] + rot[2, j] * a_pa[2]
    if not with_grad:
        return
    for j in range(3):  # turned = G_PA R, the rows of G_PA being (gxx, gxy, gxz), (gxy, gyy, gyz), (gxz, gyz, gzz)
        turned[0, j] = g[0] * rot[0, j] + g[3] * rot[1, j] + g[4] * rot[2, j]
        turned[1, j] = g[3] * rot[0, j] + g[1] * rot[1, j] + g[5] * rot[2, j]
        turned[2, j] = g[4] * rot[0, j] + g[5] * rot[1, j] + g[2] * rot[2, j]
    for i in range(3):
        for j in range(3):
            grad[i, j] += rot[0, i] * turned[0, j] + rot[1, i] * turned[1, j] + rot[2, i] * turned[2, j]


@njit(cache=True)
def add_terms_at_moon(terms, t_s, r, r_moon, gm_moon, with_grad, acc, grad):
    """acc (3,) (and with with_grad, grad (3, 3)) += every term of the table that acts from the Moon, at the
    geocentric position r, the Moon at r_moon with its GM (the one place a dated force of that kind is added)."""
    for t in range(int(terms[0]) if terms.shape[0] > 0 else 0):
        kind, start = int(terms[1 + 2 * t]), int(terms[2 + 2 * t])
        if kind == TERM_MOON_HARMONICS:
            add_moon_field(t_s, r, r_moon, gm_moon, terms[start:], with_grad, acc, grad)
        elif kind == TERM_MOON_J2:
            add_moon_j2(t_s, r, r_moon, gm_moon, terms[start:], with_grad, acc, grad)


@njit(cache=True)
def ephemeris_derivative(t_s, y, coeffs, start_s, interval_s, n_records, bodies, gms, gm_earth, cr_am, terms,
                         with_stm, out):
    """dy/dt for y = [r, v] (6,), [r, v, Phi row-major] (42,) or [r, v, Phi, s] (48,), geocentric ICRF km, km/s
    at TDB t_s. bodies / gms (B,): third bodies (codes of dynamics.ephemeris) and their GM; cr_am: C_R A/m
    (m^2/kg), 0 for no SRP (the Sun must then still be in `bodies` for its gravity); terms: the forces beyond those
    (dated_terms; NO_TERMS: none), the Moon's harmonics felt where the Moon is one of `bodies`. The
    field's pull on the Earth (the indirect term) is left out: at the Earth it is about 1e-8 of the Moon's point
    mass's pull there (4e-13 m/s^2).

    s (6,) = dx/dlambda, the state's sensitivity to a relative change of C_R (C_R -> C_R (1 + lambda) at
    lambda = 0): s' = A s + [0; a_srp], since the SRP acceleration is linear in C_R (Tapley, Schutz & Born
    2004, §4.2.1, the variational equations of a dynamic parameter)."""
    r = y[0:3]
    # One allocation for the call's small arrays (an allocation per body and per vector cost a third of the call):
    # rows 0-2 the gradient, 3 the acceleration, 4 the origin (the Earth), 5-7 scratch, then the bodies' positions.
    work = np.zeros((8 + bodies.shape[0], 3))
    grad, acc, origin = work[0:3], work[3], work[4]
    positions = work[8:]
    geocentric_positions_into(coeffs, start_s, interval_s, n_records, bodies, t_s, positions, work[5:8])
    _point_mass(acc, grad, r, origin, gm_earth, np.bool_(False), with_stm)  # no literal: one compile
    r_sun = origin  # zeros, as before, where the Sun or the Moon is not a body
    r_moon = origin
    for i in range(bodies.shape[0]):
        r_b = positions[i]
        _point_mass(acc, grad, r, r_b, gms[i], np.bool_(True), with_stm)
        if bodies[i] == BODY_SUN:
            r_sun = r_b
        elif bodies[i] == BODY_MOON:
            r_moon = r_b
            add_terms_at_moon(terms, t_s, r, r_b, gms[i], with_stm, acc, grad)
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


# A lunar orbiter whose osculating apolune is below this is flown about the Moon (dop853_ephemeris_states).
MOON_CENTRED_APOLUNE_KM = 20000.0
MOON_ACCELERATION_STEP_S = 10.0  # central difference of DE421's lunar velocity for the Moon's acceleration
# Every dated truth's DOP853 tolerances (km and km/s; dop853_ephemeris_states). Converged, not merely accurate: a
# truth's integrator error enters LinCov's dynamics-model part, so at rtol 1e-12 / atol 1e-9 a corrected orbit
# that differed in its last bits (computed under another BLAS kernel) moved 004's DRO error RMS by 0.1 m; at
# 1e-13 both agree to 1e-6 m, for about 1.7x the truth's time (0.30 -> 0.52 s for 31.8 days of a DRO).
TRUTH_RTOL = 1e-13
TRUTH_ATOL = 1e-13


def bound_to_moon(state_km, moon_km, gm_moon: float) -> bool:
    """The state (6,) flies an orbit about the Moon (state moon_km) whose osculating apolune is below
    MOON_CENTRED_APOLUNE_KM: a low, frozen or elliptical lunar orbit, not an NRHO, a halo or a DRO."""
    r, v = np.asarray(state_km[:3]) - moon_km[:3], np.asarray(state_km[3:]) - moon_km[3:]
    energy = 0.5 * float(v @ v) - gm_moon / float(np.linalg.norm(r))
    if energy >= 0.0:
        return False
    a = -gm_moon / (2.0 * energy)
    e = float(np.linalg.norm(np.cross(v, np.cross(r, v)) / gm_moon - r / np.linalg.norm(r)))
    return a * (1.0 + e) < MOON_CENTRED_APOLUNE_KM


def dop853_ephemeris_states(x0, t0_s, times_s, window, bodies, gms, gm_earth, cr_am, rtol=TRUTH_RTOL, atol=TRUTH_ATOL,
                            acceleration_km_s2=None, acceleration_table_km_s2=None, terms=NO_TERMS,
                            moon_centred=False):
    """Truth states (m, 6) at times_s by scipy's adaptive DOP853 (integrators.adaptive.dop853_samples) on the
    compiled derivative, restarted at every shadow edge (penumbra and umbra of the Earth and the Moon, located
    as events): the conical shadow's kinks would otherwise cost metres after one eclipse (a fixed-step RK8 at
    864 s: 1.6 m after 9 days; DOP853 without the restarts: 0.6 m). Tolerances TRUTH_RTOL and TRUTH_ATOL (1e-13,
    km and km/s); after 9 days with one eclipse this truth is within centimetres of itself at rtol 3e-14
    (tests/unit/dynamics/test_ephemeris.py). acceleration_km_s2 (3,): a constant extra acceleration on the ICRF
    axes (the truth's unmodelled force; None: none); acceleration_table_km_s2 (m, 3): one more, given at
    times_s and linear between them (a Gauss-Markov force drawn per run; None: none); terms: the forces beyond the
    point masses and SRP (ephemeris_derivative's). moon_centred: the integrator carries the state less the Moon's
    (DE421's, its acceleration a central difference of its velocity), so that rtol is relative to the orbit about
    the Moon: geocentric, a 100 km lunar orbit's steps were sized by 384,000 km, and the truth at rtol 1e-12 was
    2.7 m from itself at 1e-13 after a day (benchmarks.lunar_field_dated); the states returned are geocentric
    either way."""
    if moon_centred:
        return _moon_centred_states(x0, t0_s, times_s, window, bodies, gms, gm_earth, cr_am, rtol, atol,
                                    acceleration_km_s2, acceleration_table_km_s2, terms)
    args = (window.coeffs, window.start_s, window.interval_s, window.n_records)
    rhs = _geocentric_rhs(args, bodies, gms, gm_earth, cr_am, terms, acceleration_km_s2,
                          acceleration_table_km_s2, times_s)

    def edge(which, body):
        def event(t, y):
            r_sun = geocentric_state(*args, np.int64(BODY_SUN), t)[0:3]
            r_body = np.zeros(3) if body == BODY_EARTH else geocentric_state(*args, np.int64(BODY_MOON), t)[0:3]
            return shadow_edges(y[0:3], r_sun, r_body, R_EARTH_KM if body == BODY_EARTH else R_MOON_KM)[which]

        event.terminal = True
        return event

    events = [edge(w, b) for w in (0, 1) for b in (BODY_EARTH, BODY_MOON)] if cr_am > 0.0 else []
    return dop853_samples(rhs, t0_s, x0, times_s, rtol, atol, events, what="ephemeris truth propagation")


def _moon_centred_states(x0, t0_s, times_s, window, bodies, gms, gm_earth, cr_am, rtol, atol, acceleration_km_s2,
                         acceleration_table_km_s2, terms):
    """dop853_ephemeris_states flown about the Moon: y = state - moon(t), y' = f(t, y + moon(t)) - moon'(t)."""
    args = (window.coeffs, window.start_s, window.interval_s, window.n_records)

    def moon(t):
        return geocentric_state(*args, np.int64(BODY_MOON), t)

    def moon_rate(t):
        h = MOON_ACCELERATION_STEP_S
        state = moon(t)
        return np.concatenate([state[3:], (moon(t + h)[3:] - moon(t - h)[3:]) / (2.0 * h)])

    geocentric = _geocentric_rhs(args, bodies, gms, gm_earth, cr_am, terms, acceleration_km_s2,
                                 acceleration_table_km_s2, times_s)

    def rhs(t, y):
        return geocentric(t, y + moon(t)) - moon_rate(t)

    def edge(which, body):
        def event(t, y):
            r_sun = geocentric_state(*args, np.int64(BODY_SUN), t)[0:3]
            r_moon = moon(t)[0:3]
            r_body = np.zeros(3) if body == BODY_EARTH else r_moon
            return shadow_edges(y[0:3] + r_moon, r_sun, r_body, R_EARTH_KM if body == BODY_EARTH else R_MOON_KM)[which]

        event.terminal = True
        return event

    events = [edge(w, b) for w in (0, 1) for b in (BODY_EARTH, BODY_MOON)] if cr_am > 0.0 else []
    relative = dop853_samples(rhs, t0_s, np.asarray(x0, dtype=float) - moon(t0_s), times_s, rtol, atol, events,
                              what="ephemeris truth propagation")
    return relative + np.array([moon(t) for t in np.asarray(times_s, dtype=float)])


def _geocentric_rhs(args, bodies, gms, gm_earth, cr_am, terms, acceleration_km_s2, acceleration_table_km_s2,
                    times_s):
    """The truth's geocentric right-hand side (t, y) -> y' with its extra accelerations (dop853_ephemeris_states)."""
    out = np.empty(6)
    forced = acceleration_km_s2 is not None and np.any(np.asarray(acceleration_km_s2) != 0.0)
    table = None if acceleration_table_km_s2 is None else _LinearTable(times_s, acceleration_table_km_s2)

    def rhs(t, y):
        ephemeris_derivative(t, y, *args, bodies, gms, gm_earth, cr_am, terms, False, out)
        rate = out.copy()
        if forced:
            rate[3:] += acceleration_km_s2
        if table is not None:
            rate[3:] += table(t)
        return rate

    return rhs


class _LinearTable:
    """values (m, k) given at ascending times (m,), linear between them and held past either end."""

    def __init__(self, times, values):
        self.times, self.values = np.asarray(times, dtype=float), np.asarray(values, dtype=float)

    def __call__(self, t: float) -> np.ndarray:
        i = min(max(int(np.searchsorted(self.times, t, side="right")) - 1, 0), len(self.times) - 2)
        fraction = min(max((t - self.times[i]) / (self.times[i + 1] - self.times[i]), 0.0), 1.0)
        return self.values[i] + (self.values[i + 1] - self.values[i]) * fraction
