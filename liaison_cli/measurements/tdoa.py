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
    partials with respect to the receiver's and transmitter's states into g_receiver, g_transmitter (6,).
    Scalar arithmetic only: numba compiles it in a fraction of the time array expressions would take."""
    c = SPEED_OF_LIGHT_LU_TU
    d0, d1, d2 = x_receiver[0] - x_transmitter[0], x_receiver[1] - x_transmitter[1], x_receiver[2] - x_transmitter[2]
    v0, v1, v2 = x_transmitter[3], x_transmitter[4], x_transmitter[5]
    tau = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / c
    for _ in range(4):  # the fixed point w = d + v tau, tau = |w| / c
        w0, w1, w2 = d0 + v0 * tau, d1 + v1 * tau, d2 + v2 * tau
        rho = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        tau = rho / c
    w0, w1, w2 = d0 + v0 * tau, d1 + v1 * tau, d2 + v2 * tau
    rho = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    u0, u1, u2 = w0 / rho, w1 / rho, w2 / rho
    big_d = 1.0 - (u0 * v0 + u1 * v1 + u2 * v2) / c
    if not rate:
        g_receiver[0], g_receiver[1], g_receiver[2] = u0 / big_d, u1 / big_d, u2 / big_d
        g_transmitter[0], g_transmitter[1], g_transmitter[2] = -u0 / big_d, -u1 / big_d, -u2 / big_d
        g_receiver[3] = g_receiver[4] = g_receiver[5] = 0.0
        g_transmitter[3], g_transmitter[4], g_transmitter[5] = tau * u0 / big_d, tau * u1 / big_d, tau * u2 / big_d
        return rho
    dv0, dv1, dv2 = x_receiver[3] - v0, x_receiver[4] - v1, x_receiver[5] - v2
    f = (u0 * dv0 + u1 * dv1 + u2 * dv2) / big_d
    k = f / (c * big_d)
    a0, a1, a2 = dv0 / big_d + k * v0, dv1 / big_d + k * v1, dv2 / big_d + k * v2  # the coefficient of du
    au = a0 * u0 + a1 * u1 + a2 * u2
    p0, p1, p2 = (a0 - au * u0) / rho, (a1 - au * u1) / rho, (a2 - au * u2) / rho
    pv = (p0 * v0 + p1 * v1 + p2 * v2) / (c * big_d)
    q0, q1, q2 = p0 + pv * u0, p1 + pv * u1, p2 + pv * u2
    g_receiver[0], g_receiver[1], g_receiver[2] = q0, q1, q2
    g_receiver[3], g_receiver[4], g_receiver[5] = u0 / big_d, u1 / big_d, u2 / big_d
    g_transmitter[0], g_transmitter[1], g_transmitter[2] = -q0, -q1, -q2
    g_transmitter[3] = tau * q0 - u0 / big_d + k * u0
    g_transmitter[4] = tau * q1 - u1 / big_d + k * u1
    g_transmitter[5] = tau * q2 - u2 / big_d + k * u2
    return f


@njit(cache=True)  # a call, not inlined: keeps the EKF loop small for scenarios without TDoA (compile time)
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
