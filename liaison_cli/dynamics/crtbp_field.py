"""The CRTBP's field as the integrators evaluate it: its parts composed in one place. Every CRTBP integrator (the
filter's RK4, the truth's, the batch's RK8), the trajectories' accelerations and the default process noise's
field difference call these, so a part added here reaches all of them.

Parts, each with its acceleration and its gradient (the STM's):
- the primaries' point masses and the rotating frame (dynamics.crtbp, Eq. 6-8 and 11): always;
- the Moon's gravity field beyond its point mass (GRGM1200A, dynamics.lunar_gravity; evaluated by
  dynamics.spherical_harmonics): when the parameter vector carries it.

Parameter vector (plain data, so one compiled body serves every field; issue 49's "specialise on data"):
params[0] = mu; for the lunar field, params[1] = its degree, params[2] = its reference radius (LU), then C̄ and S̄
packed (spherical_harmonics.packed_index), each packed_index(degree, degree) + 1 long. The field's GM is the
CRTBP's Moon, mu (LU^3/TU^2); GRGM1200A's own GM differs from it by 2e-7 relative, which scales the harmonics'
small accelerations by as much.

Frame: the Moon is tidally locked with its principal axes on the rotating frame: x_PA = -x (towards the Earth),
y_PA = -y (against the orbital motion), z_PA = z. What that leaves out (the physical and optical librations, up to
about 8 degrees in longitude and 7 in latitude seen from the Earth, and the 1.5 degree tilt of the Moon's
equator) is measured in docs/model.md ("The Moon's gravity field").
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import LU_KM
from liaison_cli.dynamics.crtbp import derivative, derivative_into, state_stm_rhs
from liaison_cli.dynamics.spherical_harmonics import acceleration_gradient_into, packed_index

FIELD_HEADER = 3  # mu, degree, radius (LU)


def crtbp_params(mu: float, field=None) -> np.ndarray:
    """The CRTBP's parameter vector: [mu] for point masses, or with a dynamics.lunar_gravity.LunarField behind
    it (module docstring)."""
    if field is None:
        return np.array([mu])
    return np.concatenate([[mu, float(field.degree), field.radius_km / LU_KM], field.c, field.s])


def field_degree(params) -> int:
    """The lunar field's degree in a CRTBP parameter vector (0: point masses only)."""
    return int(params[1]) if len(params) > 1 else 0


@njit(cache=True)
def moon_harmonics_into(params, x, y, z, with_gradient, acc, grad):
    """acc (3,) <- the lunar field's acceleration beyond the point mass at the rotating-frame position (x, y, z);
    with with_gradient, grad (6,) <- its gradient (gxx, gyy, gzz, gxy, gxz, gyz). LU, TU."""
    mu = params[0]
    degree = int(params[1])
    size = packed_index(degree, degree) + 1
    c = params[FIELD_HEADER:FIELD_HEADER + size]
    s = params[FIELD_HEADER + size:FIELD_HEADER + 2 * size]
    # rotating frame -> principal axes about the Moon: x and y turn over, z stays
    acceleration_gradient_into(c, s, mu, params[2], degree, 1.0 - mu - x, -y, z, with_gradient, acc, grad)
    acc[0], acc[1] = -acc[0], -acc[1]
    if with_gradient:  # D G D with D = diag(-1, -1, 1): the xz and yz terms change sign
        grad[4], grad[5] = -grad[4], -grad[5]


@njit(cache=True)
def added_terms_into(params, x, y, z, with_gradient, acc, grad):
    """acc (3,) <- the sum of the field's terms beyond the primaries' point masses at (x, y, z); with
    with_gradient, grad (6,) <- their gradient. The one place a CRTBP force is added (docs/architecture.md,
    "Adding a force"): today the lunar field."""
    moon_harmonics_into(params, x, y, z, with_gradient, acc, grad)


@njit(cache=True, inline="always")
def field_derivative_into(y, params, out):
    """The state's time derivative (6,) into out[0:6] (derivative_into plus added_terms_into when params has
    terms)."""
    derivative_into(y, params[0], out)
    if params.shape[0] > 1:
        acc, grad = np.empty(3), np.empty(6)
        added_terms_into(params, y[0], y[1], y[2], False, acc, grad)
        for i in range(3):
            out[3 + i] += acc[i]


@njit(cache=True, inline="always")
def field_state_stm_rhs(y, params, out):
    """The 42-vector [state, Phi] derivative (crtbp.state_stm_rhs plus the added terms' acceleration and gradient
    when params has terms)."""
    state_stm_rhs(y, params[0], out)
    if params.shape[0] > 1:
        acc, grad = np.empty(3), np.empty(6)
        added_terms_into(params, y[0], y[1], y[2], True, acc, grad)
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
    out = derivative(state, params[0])
    if params.shape[0] > 1:
        acc, grad = np.empty(3), np.empty(6)
        added_terms_into(params, state[0], state[1], state[2], False, acc, grad)
        for i in range(3):
            out[3 + i] += acc[i]
    return out
