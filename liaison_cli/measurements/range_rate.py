"""Instantaneous range-rate (001 Eq. 20-21 geometry): rho_dot = (r . v) / |r| with the relative position
r = r_receiver - r_transponder and velocity v = v_receiver - v_transponder (rotating frame). Truth is the
same geometry at the reception time: its light-time terms are far below the range-rate noise."""

import numpy as np
from numba import njit

from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.constants import M_S_PER_VU
from liaison_cli.measurements.observable import ChannelKind, Observable

KIND_RANGE_RATE = 1


# Scalar arithmetic, no array expressions: `a[0:3] - b[0:3]` allocates at every call and compiles numba's
# broadcasting machinery (about 0.3 s of every first run per function).
@njit(cache=True)
def range_rate(x_receiver, x_transponder):
    """(6,), (6,) -> float (LU/TU)."""
    r0, r1, r2 = x_receiver[0] - x_transponder[0], x_receiver[1] - x_transponder[1], x_receiver[2] - x_transponder[2]
    v0, v1, v2 = x_receiver[3] - x_transponder[3], x_receiver[4] - x_transponder[4], x_receiver[5] - x_transponder[5]
    return (r0 * v0 + r1 * v1 + r2 * v2) / np.sqrt(r0**2 + r1**2 + r2**2)


@njit(cache=True)
def range_rate_gradient(x_receiver, x_transponder):
    """d(rho_dot)/d(x_receiver) (6,): [(v - rho_dot u) / rho, u] with u = r / rho. The transponder's
    gradient is its negative."""
    r = np.empty(3)
    v = np.empty(3)
    for i in range(3):
        r[i] = x_receiver[i] - x_transponder[i]
        v[i] = x_receiver[3 + i] - x_transponder[3 + i]
    rho = np.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
    u0, u1, u2 = r[0] / rho, r[1] / rho, r[2] / rho
    rho_dot = u0 * v[0] + u1 * v[1] + u2 * v[2]
    out = np.empty(6)
    out[0], out[1], out[2] = (v[0] - rho_dot * u0) / rho, (v[1] - rho_dot * u1) / rho, (v[2] - rho_dot * u2) / rho
    out[3], out[4], out[5] = u0, u1, u2
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
    # Writable (copied only if read-only): a read-only array would compile range_rate once more for its own signature.
    receivers, transponders = (writable_c(end.states) for end in (receiver, transponder))
    return np.array([range_rate(a, b) for a, b in zip(receivers, transponders)])


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
