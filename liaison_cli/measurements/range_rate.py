"""Instantaneous crosslink range-rate (001 Eq. 20-21 geometry): rho_dot = (r . v) / |r| with the relative
position r = r_receiver - r_transponder and velocity v = v_receiver - v_transponder (rotating frame)."""

import numpy as np
from numba import njit


@njit(cache=True)
def range_rate(x_receiver, x_transponder):
    """(6,), (6,) -> float (LU/TU)."""
    r = x_receiver[0:3] - x_transponder[0:3]
    v = x_receiver[3:6] - x_transponder[3:6]
    return (r[0] * v[0] + r[1] * v[1] + r[2] * v[2]) / np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)


@njit(cache=True)
def range_rate_gradient(x_receiver, x_transponder):
    """d(rho_dot)/d(x_receiver) (6,): [(v - rho_dot u) / rho, u] with u = r / rho. The transponder's
    gradient is its negative."""
    r = x_receiver[0:3] - x_transponder[0:3]
    v = x_receiver[3:6] - x_transponder[3:6]
    rho = np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
    u = r / rho
    rho_dot = u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    out = np.empty(6)
    out[0:3] = (v - rho_dot * u) / rho
    out[3:6] = u
    return out
