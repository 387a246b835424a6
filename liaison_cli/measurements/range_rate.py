"""Instantaneous range-rate (001 Eq. 20-21 geometry): rho_dot = (r . v) / |r| with the relative position
r = r_receiver - r_transponder and velocity v = v_receiver - v_transponder (rotating frame). Truth is the
same geometry at the reception time: its light-time terms are far below the range-rate noise."""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import M_S_PER_VU
from liaison_cli.measurements.observable import ChannelKind, Observable

KIND_RANGE_RATE = 1


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
    for i in range(3):  # element loops compile faster than slice assignment (no shape-error path)
        out[i] = (v[i] - rho_dot * u[i]) / rho
        out[3 + i] = u[i]
    return out


@njit(cache=True, inline="always")
def predict_range_rate(x_receiver, x_transponder, flags, g_receiver, g_transponder):
    """Value (LU/TU) and partials with respect to both ends' states (6,) each."""
    g = range_rate_gradient(x_receiver, x_transponder)
    for i in range(6):
        g_receiver[i] = g[i]
        g_transponder[i] = -g[i]
    return range_rate(x_receiver, x_transponder)


def _simulate(code, receiver, transponder, light_time: bool):
    return np.array([range_rate(a, b) for a, b in zip(receiver.states, transponder.states)])


def _sigma(noise, receiver):
    return (noise.resolved_range_rate_sigma_m_s() / M_S_PER_VU,)


OBSERVABLE = Observable(
    name="range_rate",
    channels=(ChannelKind(KIND_RANGE_RATE, "range_rate", "m/s", M_S_PER_VU),),
    sigma=_sigma,
    simulate=_simulate,
    missing_noise=lambda noise: (None if noise.resolved_range_rate_sigma_m_s() is not None
                                 else "give noise.range_rate_sigma_m_s or noise.carrier"),
    description="instantaneous range-rate (Doppler); sigma: noise.range_rate_sigma_m_s or noise.carrier",
)
