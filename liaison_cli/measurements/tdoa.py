"""Time and frequency difference of arrival (004 §3): one transmitter's signal received at two receivers.

With rho_i = |r_i - r_t| the path to receiver i and rho_dot_i its rate (instantaneous geometry, as the
other observables of dated scenarios):
- TDoA = (rho_2 - rho_1) / c: the signal reaches the second receiver this much later than the first. In the
  filter the channel carries the path difference rho_2 - rho_1 (LU); its SI unit is the second
  (scale LU / c).
- FDoA = f_2 - f_1 = (f_c / c) (rho_dot_1 - rho_dot_2): the first-order Doppler difference of a carrier f_c.
  The channel carries the range-rate difference rho_dot_1 - rho_dot_2 (LU/TU, SI m/s); its sigma comes from
  the Hz value and the scenario's carrier, sigma_m_s = sigma_Hz c / f_c.
Ends: `receiver` (1), `transponder` (the transmitter) and `second_receiver` (2). The partials are those of
range and range-rate, with opposite signs at the two receivers; the transmitter's are their difference.

Light time (flag FLAG_LIGHT_TIME: `measurement.light_time` in the truth, `filter.range_model: light_time` in
the filter): both receivers record at the same time t, each hearing what the transmitter sent at t - tau_i,
|r_i(t) - r_t(t - tau_i)| = c tau_i. Over tau (1-2 s in cislunar space) the transmitter moves in a straight
line, r_t(t - tau) = r_t - v_t tau: the neglected curvature is a tau^2 / 2 < 3 mm of path and a tau < 4 mm/s
of velocity, which the difference of two paths cancels to < 1 mm/s (sigma: 6 m and 5 mm/s). With
w = d + v_t tau, u = w / rho and D = 1 - u . v_t / c:
  rho_i = |w| (fixed point in tau, 3 iterations: contraction |v| / c ~ 1e-5),
  rho_dot_i = u . (v_i - v_t) / D (the emission-time derivative dt_e / dt = 1 - rho_dot / c).
Their partials follow from d rho = (u . dd + tau u . dv_t) / D and du = (I - u u') dw / rho.
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import LU_KM, M_S_PER_VU, SPEED_OF_LIGHT_KM_S, SPEED_OF_LIGHT_LU_TU
from liaison_cli.measurements.observable import ChannelKind, Observable
from liaison_cli.measurements.range import FLAG_LIGHT_TIME, geometric_range, geometric_range_gradient, light_time_flags
from liaison_cli.measurements.range_rate import range_rate, range_rate_gradient

KIND_TDOA = 9
KIND_FDOA = 10
SECONDS_PER_LU = LU_KM / SPEED_OF_LIGHT_KM_S  # light time across one LU of path difference


@njit(cache=True)
def light_time_path(x_receiver, x_transmitter, rate, g_receiver, g_transmitter):
    """One signal path with light time (module docstring): rho (LU) or, with `rate`, rho_dot (LU/TU); the
    partials with respect to the receiver's and transmitter's states into g_receiver, g_transmitter (6,)."""
    c = SPEED_OF_LIGHT_LU_TU
    d = x_receiver[0:3] - x_transmitter[0:3]
    v_t = x_transmitter[3:6]
    tau = np.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2) / c
    for _ in range(3):
        w = d + v_t * tau
        rho = np.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
        tau = rho / c
    w = d + v_t * tau
    rho = np.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
    u = w / rho
    big_d = 1.0 - (u[0] * v_t[0] + u[1] * v_t[1] + u[2] * v_t[2]) / c
    if not rate:
        for i in range(3):
            g_receiver[i] = u[i] / big_d
            g_receiver[3 + i] = 0.0
            g_transmitter[i] = -u[i] / big_d
            g_transmitter[3 + i] = tau * u[i] / big_d
        return rho
    dv = x_receiver[3:6] - v_t
    f = (u[0] * dv[0] + u[1] * dv[1] + u[2] * dv[2]) / big_d
    a = dv / big_d + f * v_t / (c * big_d)  # the coefficient of du
    p = (a - (a[0] * u[0] + a[1] * u[1] + a[2] * u[2]) * u) / rho
    q = p + (p[0] * v_t[0] + p[1] * v_t[1] + p[2] * v_t[2]) / (c * big_d) * u
    for i in range(3):
        g_receiver[i] = q[i]
        g_receiver[3 + i] = u[i] / big_d
        g_transmitter[i] = -q[i]
        g_transmitter[3 + i] = tau * q[i] - u[i] / big_d + f * u[i] / (c * big_d)
    return f


@njit(cache=True, inline="always")
def predict_difference(kind, x_first, x_transmitter, x_second, flags, g_first, g_transmitter, g_second):
    """TDoA path difference rho_2 - rho_1 or FDoA rate difference rho_dot_1 - rho_dot_2 (filter units),
    with the partials with respect to the three ends' states (6,) each; FLAG_LIGHT_TIME: each path with
    its own light time."""
    if flags & FLAG_LIGHT_TIME:
        rate = kind == KIND_FDOA
        g1_t = np.empty(6)
        g2_t = np.empty(6)
        first = light_time_path(x_first, x_transmitter, rate, g_first, g1_t)
        second = light_time_path(x_second, x_transmitter, rate, g_second, g2_t)
        sign = 1.0 if rate else -1.0  # TDoA: rho_2 - rho_1; FDoA: rho_dot_1 - rho_dot_2
        for i in range(6):
            g_first[i] *= sign
            g_second[i] *= -sign
            g_transmitter[i] = sign * (g1_t[i] - g2_t[i])
        return sign * (first - second)
    if kind == KIND_TDOA:
        g1 = geometric_range_gradient(x_first[0:3], x_transmitter[0:3])
        g2 = geometric_range_gradient(x_second[0:3], x_transmitter[0:3])
        for i in range(3):
            g_first[i] = -g1[i]
            g_second[i] = g2[i]
            g_transmitter[i] = g1[i] - g2[i]
            g_first[3 + i] = 0.0
            g_second[3 + i] = 0.0
            g_transmitter[3 + i] = 0.0
        return geometric_range(x_second[0:3], x_transmitter[0:3]) - geometric_range(x_first[0:3], x_transmitter[0:3])
    g1 = range_rate_gradient(x_first, x_transmitter)
    g2 = range_rate_gradient(x_second, x_transmitter)
    for i in range(6):
        g_first[i] = g1[i]
        g_second[i] = -g2[i]
        g_transmitter[i] = g2[i] - g1[i]
    return range_rate(x_first, x_transmitter) - range_rate(x_second, x_transmitter)


def _simulate(code, receiver, transmitter, light_time: bool, second=None):
    flags = FLAG_LIGHT_TIME if light_time else 0
    g = np.empty(6)
    return np.array([predict_difference(code, a, b, c, flags, g, g.copy(), g.copy())
                     for a, b, c in zip(receiver.states, transmitter.states, second.states)])


def _sigma_tdoa(noise, receiver):
    return (noise.tdoa_sigma_ns * 1e-9 / SECONDS_PER_LU,)


def _sigma_fdoa(noise, receiver):
    sigma_m_s = noise.fdoa_sigma_hz * SPEED_OF_LIGHT_KM_S * 1e3 / noise.carrier_frequency_hz
    return (sigma_m_s / M_S_PER_VU,)


def _missing_tdoa(noise):
    return None if noise.tdoa_sigma_ns is not None else "the noise section has no 'tdoa_sigma_ns' (004: 20 ns)"


def _missing_fdoa(noise):
    missing = [key for key in ("fdoa_sigma_hz", "carrier_frequency_hz") if getattr(noise, key) is None]
    if not missing:
        return None
    return f"the noise section has no {' / '.join(repr(k) for k in missing)} (004: 0.04 Hz; the carrier is yours)"


TDOA = Observable(
    name="tdoa",
    channels=(ChannelKind(KIND_TDOA, "tdoa", "s", SECONDS_PER_LU),),
    sigma=_sigma_tdoa,
    simulate=_simulate,
    needs_second_receiver=True,
    light_time_from_states=True,
    filter_flags=light_time_flags,
    missing_noise=_missing_tdoa,
    description="time difference of arrival at the second receiver minus the first (s)",
)

FDOA = Observable(
    name="fdoa",
    channels=(ChannelKind(KIND_FDOA, "fdoa", "m/s", M_S_PER_VU),),
    sigma=_sigma_fdoa,
    simulate=_simulate,
    needs_second_receiver=True,
    light_time_from_states=True,
    filter_flags=light_time_flags,
    missing_noise=_missing_fdoa,
    description="frequency difference of arrival as the range-rate difference (m/s); Hz = value f_c / c",
)
