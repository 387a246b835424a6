"""The CRTBP's field as the integrators evaluate it: its parts composed in one place. Every CRTBP integrator (the
filter's RK4, the truth's, the batch's RK8), the trajectories' accelerations and the default process noise's
field difference call these, so a part added here reaches all of them.

Parts, each with its acceleration and its gradient (the STM's):
- the primaries' point masses and the rotating frame (dynamics.crtbp, Eq. 6-8 and 11): always;
- TERM_HARMONICS: the Moon's gravity field beyond its point mass (GRGM1200A, dynamics.lunar_gravity; evaluated
  by dynamics.spherical_harmonics);
- TERM_J2: the Moon's J2 alone, in closed form (dynamics.zonal_j2; GRGM1200A's -sqrt(5) C̄20): a flight filter's
  usual field.

Parameter vector (plain data, so one compiled body serves every field; issue 49's "specialise on data"):
params[0] = mu; with added terms, params[1] = their count T, then T pairs (kind, start of its payload), then the
payloads. TERM_HARMONICS: spherical_harmonics.field_payload with the reference radius in LU (degree, radius, the
recursions' factors and the field's weight tables); TERM_J2: J2, reference radius (LU). A point-mass CRTBP is
[mu] alone (the golden record's arithmetic, bit for bit). Every term's GM is the CRTBP's Moon, mu (LU^3/TU^2);
GRGM1200A's own GM differs from it by 2e-7 relative, which scales the terms' small accelerations by as much.

Frame: the Moon is tidally locked with its principal axes on the rotating frame: x_PA = -x (towards the Earth),
y_PA = -y (against the orbital motion), z_PA = z. What that leaves out (the physical and optical librations, up to
about 8 degrees in longitude and 7 in latitude seen from the Earth, and the 1.5 degree tilt of the Moon's
equator) is measured in docs/model.md ("The Moon's gravity field").
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import LU_KM
from liaison_cli.dynamics.crtbp import derivative_into, state_stm_rhs, truth_derivative_into
from liaison_cli.dynamics.spherical_harmonics import (field_acceleration_scratch_into, field_payload,
                                                       harmonics_scratch_size, payload_tables, point_scratch_size)
from liaison_cli.dynamics.zonal_j2 import j2_acceleration_gradient_into

TERM_HARMONICS = 1  # payload: spherical_harmonics.field_payload, radius in LU
TERM_J2 = 2  # payload: J2, radius (LU)


def harmonics_term(field) -> tuple[int, np.ndarray]:
    """(TERM_HARMONICS, payload) of a dynamics.lunar_gravity.LunarField (spherical_harmonics.field_payload, radius in
    LU)."""
    return TERM_HARMONICS, field_payload(field.c, field.s, field.degree, field.radius_km / LU_KM)


def j2_term(j2: float, radius_km: float) -> tuple[int, np.ndarray]:
    """(TERM_J2, payload): a J2 (unnormalised) and its reference radius, e.g. lunar_gravity.lunar_j2()'s."""
    return TERM_J2, np.array([j2, radius_km / LU_KM])


def crtbp_params(mu: float, *terms) -> np.ndarray:
    """The CRTBP's parameter vector (module docstring): [mu] for point masses, else the terms' table and payloads;
    terms: (kind, payload) pairs (harmonics_term, j2_term). A None term is left out."""
    terms = [term for term in terms if term is not None]
    if not terms:
        return np.array([mu])
    table, payloads, start = [], [], 2 + 2 * len(terms)
    for kind, payload in terms:
        table += [float(kind), float(start)]
        payloads.append(np.asarray(payload, dtype=float))
        start += len(payload)
    return np.concatenate([[mu, float(len(terms))], table, *payloads])


def has_added_terms(params) -> bool:
    """The vector carries terms beyond the primaries' point masses."""
    return len(params) > 1


def term_payload(params, kind: int):
    """The payload of the first term of `kind` in a parameter vector (None when it has none)."""
    for t in range(int(params[1]) if len(params) > 1 else 0):
        if int(params[2 + 2 * t]) == kind:
            return params[int(params[3 + 2 * t]):]
    return None


def field_degree(params) -> int:
    """The lunar harmonics' degree in a CRTBP parameter vector (0: none; a J2 term alone counts 0)."""
    payload = term_payload(params, TERM_HARMONICS)
    return 0 if payload is None else int(payload[0])


@njit(cache=True)
def moon_harmonics_into(params, start, x, y, z, with_gradient, acc, grad):
    """acc (3,) <- the lunar harmonics' acceleration beyond the point mass (payload at params[start:]) at the
    rotating-frame position (x, y, z); with with_gradient, grad (6,) <- its gradient (gxx, gyy, gzz, gxy, gxz,
    gyz). LU, TU. Allocates its scratch (the integrators' path, added_terms_scratch_into, passes its own)."""
    mu = params[0]
    degree, radius = int(params[start]), params[start + 1]
    size = point_scratch_size(degree, radius, 1.0 - mu - x, -y, z)  # the principal axes (_moon_harmonics_scratch_into)
    _moon_harmonics_scratch_into(params, start, x, y, z, with_gradient, acc, grad, np.empty(size), np.empty(size))


@njit(cache=True)
def _moon_harmonics_scratch_into(params, start, x, y, z, with_gradient, acc, grad, v, w):
    """moon_harmonics_into with the scratch tables v, w (spherical_harmonics.field_acceleration_scratch_into)."""
    mu = params[0]
    degree, radius, tables = payload_tables(params[start:])
    # rotating frame -> principal axes about the Moon: x and y turn over, z stays
    field_acceleration_scratch_into(tables, mu, radius, degree, 1.0 - mu - x, -y, z, with_gradient, acc, grad, v, w)
    acc[0], acc[1] = -acc[0], -acc[1]
    if with_gradient:  # D G D with D = diag(-1, -1, 1): the xz and yz terms change sign
        grad[4], grad[5] = -grad[4], -grad[5]


@njit(cache=True)
def moon_j2_into(params, start, x, y, z, with_gradient, acc, grad):
    """As moon_harmonics_into for the Moon's J2 alone (payload: J2, radius LU). J2 is symmetric about z, so the
    principal axes' turn of x and y (both signs) leaves its acceleration and gradient unchanged."""
    j2_acceleration_gradient_into(params[0], params[start], params[start + 1], x - (1.0 - params[0]), y, z,
                                  with_gradient, acc, grad)


# Scratch of added_terms_scratch_into: one term's acceleration (3) and gradient (6), then the harmonics' two tables
# (V̄, W̄), each as long as the largest harmonics term needs.
RESULT_SCRATCH = 9


@njit(cache=True)
def terms_scratch_size(params):
    """The scratch length added_terms_scratch_into needs for the terms of `params`."""
    tables = 0
    for t in range(int(params[1])):
        kind, start = int(params[2 + 2 * t]), int(params[3 + 2 * t])
        if kind == TERM_HARMONICS:
            tables = max(tables, harmonics_scratch_size(int(params[start])))
    return RESULT_SCRATCH + 2 * tables


@njit(cache=True)
def added_terms_into(params, x, y, z, with_gradient, acc, grad):
    """acc (3,) <- the sum of the terms beyond the primaries' point masses at (x, y, z); with with_gradient,
    grad (6,) <- their gradient. The one place a CRTBP force is added (docs/architecture.md, "Adding a force"):
    each term of the vector's table, by its kind (added_terms_scratch_into, with its scratch allocated here)."""
    added_terms_scratch_into(params, x, y, z, with_gradient, acc, grad, np.empty(terms_scratch_size(params)))


@njit(cache=True)
def added_terms_scratch_into(params, x, y, z, with_gradient, acc, grad, scratch):
    """added_terms_into with the caller's scratch (at least terms_scratch_size(params) long, overwritten)."""
    for i in range(3):
        acc[i] = 0.0
    for i in range(6):
        grad[i] = 0.0
    term_acc, term_grad = scratch[0:3], scratch[3:RESULT_SCRATCH]
    tables = (scratch.shape[0] - RESULT_SCRATCH) // 2
    v, w = scratch[RESULT_SCRATCH:RESULT_SCRATCH + tables], scratch[RESULT_SCRATCH + tables:RESULT_SCRATCH + 2 * tables]
    for t in range(int(params[1])):
        kind, start = int(params[2 + 2 * t]), int(params[3 + 2 * t])
        if kind == TERM_HARMONICS:
            _moon_harmonics_scratch_into(params, start, x, y, z, with_gradient, term_acc, term_grad, v, w)
        elif kind == TERM_J2:
            moon_j2_into(params, start, x, y, z, with_gradient, term_acc, term_grad)
        else:
            continue
        for i in range(3):
            acc[i] += term_acc[i]
        if with_gradient:
            for i in range(6):
                grad[i] += term_grad[i]


@njit(cache=True, inline="always")
def field_scratch(params, spare):
    """The integrators' scratch for the added terms' evaluations, allocated once per call of an integrator instead of
    six times per evaluation (which was an eighth of a degree-20 field's propagation): the sum's acceleration and
    gradient (RESULT_SCRATCH), then added_terms_scratch_into's. With no added terms, an empty view of `spare` (any
    1-D float array of the caller): no allocation and no call on the point-mass path (inlined; the allocation is
    a call, see _add_terms_to_derivative)."""
    if params.shape[0] > 1:
        return _allocated_scratch(params)
    return spare[0:0]


@njit(cache=True)
def _allocated_scratch(params):
    return np.empty(RESULT_SCRATCH + terms_scratch_size(params))


@njit(cache=True, inline="always")
def field_derivative_into(y, params, out, scratch):
    """The state's time derivative (6,) into out[0:6] (derivative_into plus the added terms when params has
    them); scratch: field_scratch(params, ...) of the caller."""
    derivative_into(y, params[0], out)
    if params.shape[0] > 1:
        _add_terms_to_derivative(y, params, out, scratch)


@njit(cache=True, inline="always")
def field_state_stm_rhs(y, params, out, scratch):
    """The 42-vector [state, Phi] derivative (crtbp.state_stm_rhs plus the added terms' acceleration and gradient
    when params has terms); scratch: field_scratch(params, ...) of the caller."""
    state_stm_rhs(y, params[0], out)
    if params.shape[0] > 1:
        _add_terms_to_state_stm_rhs(y, params, out, scratch)


# The two below are calls, not inlined: with the terms' scratch allocation inlined into the integrators' hot loop,
# a point-mass CRTBP run (which never takes the branch) was 1.55x slower (eml2_lunar's filter, 31 ms against 20).
@njit(cache=True)
def _add_terms_to_derivative(y, params, out, scratch):
    """out[3:6] += the added terms' acceleration at y's position (field_derivative_into)."""
    acc, grad = scratch[0:3], scratch[3:RESULT_SCRATCH]
    added_terms_scratch_into(params, y[0], y[1], y[2], np.bool_(False), acc, grad,  # no literal: one compile
                             scratch[RESULT_SCRATCH:])
    for i in range(3):
        out[3 + i] += acc[i]


@njit(cache=True)
def _add_terms_to_state_stm_rhs(y, params, out, scratch):
    """out (42,) += the added terms' acceleration and their gradient times Phi's position rows (field_state_stm_rhs)."""
    acc, grad = scratch[0:3], scratch[3:RESULT_SCRATCH]
    added_terms_scratch_into(params, y[0], y[1], y[2], np.bool_(True), acc, grad,  # no literal: one compile
                             scratch[RESULT_SCRATCH:])
    gxx, gyy, gzz, gxy, gxz, gyz = grad[0], grad[1], grad[2], grad[3], grad[4], grad[5]
    for i in range(3):
        out[3 + i] += acc[i]
    for j in range(6):
        p0, p1, p2 = y[6 + j], y[12 + j], y[18 + j]
        out[24 + j] += gxx * p0 + gxy * p1 + gxz * p2
        out[30 + j] += gxy * p0 + gyy * p1 + gyz * p2
        out[36 + j] += gxz * p0 + gyz * p1 + gzz * p2


@njit(cache=True)
def field_derivative(state, params):
    """(6,) -> (6,): the truth's derivative (crtbp.derivative's arithmetic, so a point-mass truth is the recorded
    one bit for bit) plus the added terms when params has them."""
    out = np.empty(6)
    field_truth_derivative_into(state, params, out, field_scratch(params, out))
    return out


@njit(cache=True, inline="always")
def field_truth_derivative_into(state, params, out, scratch):
    """field_derivative into out[0:6], no allocation (the truth's RK4 stages); scratch: field_scratch(params, ...)."""
    truth_derivative_into(state, params[0], out)
    if params.shape[0] > 1:
        _add_terms_to_derivative(state, params, out, scratch)


@njit(cache=True)
def field_accelerations(states, params):
    """(m, 6) states -> (m, 3) rotating-frame accelerations: field_derivative's, sample by sample (one compiled call
    for a trajectory; a Python loop over field_derivative cost a design candidate 30 ms)."""
    out = np.empty((states.shape[0], 3))
    for k in range(states.shape[0]):
        rate = field_derivative(states[k], params)
        for i in range(3):
            out[k, i] = rate[3 + i]
    return out
