"""Circular restricted three-body problem (Turan et al. 2022, Eq. 6-8) and its variational equations: the
right-hand sides the integrators (dynamics.integrators) step, the Jacobian and the Jacobi constant.

State layout of one spacecraft: ``[x, y, z, vx, vy, vz]`` in LU and LU/TU, rotating barycentric frame.
All functions are numba-compiled (cached on disk) and work on plain float64 arrays.

The equations are written once: `primary_terms` (distances to the primaries and their 1/r^3 weights),
`_state_rate_into` (Eq. 6-8) and `_gradient_from_terms` (Eq. 11's d(acceleration)/d(position)), behind
`derivative_into` and `gravity_gradient_terms`. The integrators' kernels take them from here:
`state_stm_rhs` (the filter's RK4 and the batch's RK8 state + STM, integrators.rk4 and integrators.rk8),
`derivative_into` (the 6-state RK8), `gravity_gradient` and `jacobian`. They are scalar code with no
temporaries, inlined into their callers: the state + STM right-hand side is the innermost loop of every run.
`derivative` (the truth's, through integrators.rk4.rk4_states) writes the same equations in the recorded
truth's floating-point form: see its docstring.
"""

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def primary_terms(x, y, z, mu):
    """(dx1, dx2, r1^2, r2^2, k1, k2): offsets along x from the Earth (-mu, 0, 0) and the Moon (1 - mu, 0, 0),
    squared distances, and k1 = (1 - mu) / r1^3, k2 = mu / r2^3."""
    dx1 = x + mu
    dx2 = x - 1.0 + mu
    r1_2 = dx1 * dx1 + y * y + z * z
    r2_2 = dx2 * dx2 + y * y + z * z
    k1 = (1.0 - mu) / (r1_2 * np.sqrt(r1_2))
    k2 = mu / (r2_2 * np.sqrt(r2_2))
    return dx1, dx2, r1_2, r2_2, k1, k2


@njit(cache=True, inline="always")
def _state_rate_into(y, out, x, yy, z, dx1, dx2, k1, k2):
    """Eq. 6-8 from primary_terms: velocities, then the accelerations, into out[0:6]."""
    out[0] = y[3]
    out[1] = y[4]
    out[2] = y[5]
    out[3] = 2.0 * y[4] + x - k1 * dx1 - k2 * dx2
    out[4] = -2.0 * y[3] + yy - (k1 + k2) * yy
    out[5] = -(k1 + k2) * z


@njit(cache=True, inline="always")
def _gradient_from_terms(y, z, dx1, dx2, r1_2, r2_2, k1, k2):
    """Eq. 11's gravity gradient from primary_terms: (gxx, gyy, gzz, gxy, gxz, gyz), centrifugal included."""
    c1 = 3.0 * k1 / r1_2
    c2 = 3.0 * k2 / r2_2
    gxx = c1 * dx1 * dx1 + c2 * dx2 * dx2 - k1 - k2 + 1.0
    gyy = (c1 + c2) * y * y - k1 - k2 + 1.0
    gzz = (c1 + c2) * z * z - k1 - k2
    gxy = (c1 * dx1 + c2 * dx2) * y
    gxz = (c1 * dx1 + c2 * dx2) * z
    gyz = (c1 + c2) * y * z
    return gxx, gyy, gzz, gxy, gxz, gyz


@njit(cache=True, inline="always")
def derivative_into(y, mu, out):
    """Eq. 6-8: the time derivative of the state y[0:6] written into out[0:6], no allocation (y and out may
    be longer: the state + STM vector)."""
    x, yy, z = y[0], y[1], y[2]
    dx1, dx2, _, _, k1, k2 = primary_terms(x, yy, z, mu)
    _state_rate_into(y, out, x, yy, z, dx1, dx2, k1, k2)


@njit(cache=True, inline="always")
def gravity_gradient_terms(x, y, z, mu):
    """The symmetric d(acceleration)/d(position), centrifugal terms included, as (gxx, gyy, gzz, gxy, gxz,
    gyz)."""
    dx1, dx2, r1_2, r2_2, k1, k2 = primary_terms(x, y, z, mu)
    return _gradient_from_terms(y, z, dx1, dx2, r1_2, r2_2, k1, k2)


@njit(cache=True)
def derivative(state, mu):
    """Time derivative of one spacecraft state (6,) -> (6,). Eq. 6-8, as the truth integrates it
    (truth_derivative_into)."""
    out = np.empty(6)
    truth_derivative_into(state, mu, out)
    return out


@njit(cache=True, inline="always")
def truth_derivative_into(state, mu, out):
    """derivative's arithmetic into out[0:6], no allocation (the truth's RK4 calls it four times a step).

    The one expression kept apart from derivative_into: the same equations with r^3 = (r^2)^1.5 and the
    two primaries' terms summed one by one, as the recorded truth (tests/golden) was computed. Through
    derivative_into (r^2 sqrt(r^2)) the truth moves 1.4e-13 relative over one TU, which the dated
    scenarios' multiple shooting turns into 7.9e-6 of eph_eml1_eml2_dsn's mean NEES (measured), beyond the
    golden tolerance of 1e-7; the integrators' kernels keep r^2 sqrt(r^2), as fast as before, where pow
    made every run 25 % slower (measured). Unify when the golden runs are next re-recorded."""
    x, y, z, vx, vy, vz = state[0], state[1], state[2], state[3], state[4], state[5]
    dx1 = x + mu
    dx2 = x - 1.0 + mu
    k1 = (1.0 - mu) / (dx1 * dx1 + y * y + z * z) ** 1.5
    k2 = mu / (dx2 * dx2 + y * y + z * z) ** 1.5
    out[0] = vx
    out[1] = vy
    out[2] = vz
    out[3] = 2.0 * vy + x - k1 * dx1 - k2 * dx2
    out[4] = -2.0 * vx + y - k1 * y - k2 * y
    out[5] = -k1 * z - k2 * z


@njit(cache=True)
def gravity_gradient(position, mu):
    """Symmetric 3x3 matrix d(acceleration)/d(position), centrifugal term included. (3,) -> (3, 3)."""
    gxx, gyy, gzz, gxy, gxz, gyz = gravity_gradient_terms(position[0], position[1], position[2], mu)
    g = np.empty((3, 3))
    g[0, 0], g[0, 1], g[0, 2] = gxx, gxy, gxz
    g[1, 0], g[1, 1], g[1, 2] = gxy, gyy, gyz
    g[2, 0], g[2, 1], g[2, 2] = gxz, gyz, gzz
    return g


@njit(cache=True)
def jacobian(state, mu):
    """A = dF/dX for one spacecraft (Eq. 11 block), (6,) -> (6, 6)."""
    a = np.zeros((6, 6))
    a[0, 3] = 1.0
    a[1, 4] = 1.0
    a[2, 5] = 1.0
    g = gravity_gradient(state[0:3], mu)
    for i in range(3):  # element loops compile faster than slice assignment (no shape-error path)
        for j in range(3):
            a[3 + i, j] = g[i, j]
    a[3, 4] = 2.0
    a[4, 3] = -2.0
    return a


@njit(cache=True)
def state_stm_rhs(y, mu, out):
    """In-place derivative of the 42-vector y = [state (6), Phi row-major (36)]: Eq. 6-8 and Eq. 11.

    The position is read and primary_terms computed once, before anything is written to out (which the
    compiler cannot prove distinct from y): the innermost loop of every run."""
    x, yy, z = y[0], y[1], y[2]
    dx1, dx2, r1_2, r2_2, k1, k2 = primary_terms(x, yy, z, mu)
    gxx, gyy, gzz, gxy, gxz, gyz = _gradient_from_terms(yy, z, dx1, dx2, r1_2, r2_2, k1, k2)
    _state_rate_into(y, out, x, yy, z, dx1, dx2, k1, k2)
    for j in range(6):
        p0 = y[6 + j]
        p1 = y[12 + j]
        p2 = y[18 + j]
        p3 = y[24 + j]
        p4 = y[30 + j]
        out[6 + j] = p3
        out[12 + j] = p4
        out[18 + j] = y[36 + j]
        out[24 + j] = gxx * p0 + gxy * p1 + gxz * p2 + 2.0 * p4
        out[30 + j] = gxy * p0 + gyy * p1 + gyz * p2 - 2.0 * p3
        out[36 + j] = gxz * p0 + gyz * p1 + gzz * p2


@njit(cache=True)
def state_stm_derivative(y, mu):
    """Derivative of [state (6), Phi row-major (36)] as a new (42,) array (for scipy integrators)."""
    out = np.empty(42)
    state_stm_rhs(y, mu, out)
    return out


@njit(cache=True)
def jacobi_constant(state, mu):
    """C = 2U - v^2 with U = (x^2+y^2)/2 + (1-mu)/r1 + mu/r2. (6,) -> float."""
    x, y, z = state[0], state[1], state[2]
    r1 = np.sqrt((x + mu) ** 2 + y * y + z * z)
    r2 = np.sqrt((x - 1.0 + mu) ** 2 + y * y + z * z)
    u = 0.5 * (x * x + y * y) + (1.0 - mu) / r1 + mu / r2
    return 2.0 * u - (state[3] ** 2 + state[4] ** 2 + state[5] ** 2)
