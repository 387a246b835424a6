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
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import LU_KM, M_S_PER_VU, SPEED_OF_LIGHT_KM_S
from liaison_cli.measurements.observable import ChannelKind, Observable
from liaison_cli.measurements.range import geometric_range, geometric_range_gradient
from liaison_cli.measurements.range_rate import range_rate, range_rate_gradient

KIND_TDOA = 9
KIND_FDOA = 10
SECONDS_PER_LU = LU_KM / SPEED_OF_LIGHT_KM_S  # light time across one LU of path difference


@njit(cache=True, inline="always")
def predict_difference(kind, x_first, x_transmitter, x_second, g_first, g_transmitter, g_second):
    """TDoA path difference rho_2 - rho_1 or FDoA rate difference rho_dot_1 - rho_dot_2 (filter units),
    with the partials with respect to the three ends' states (6,) each."""
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
    g = np.empty(6)
    return np.array([predict_difference(code, a, b, c, g, g.copy(), g.copy())
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
    missing_noise=_missing_tdoa,
    description="time difference of arrival at the second receiver minus the first (s)",
)

FDOA = Observable(
    name="fdoa",
    channels=(ChannelKind(KIND_FDOA, "fdoa", "m/s", M_S_PER_VU),),
    sigma=_sigma_fdoa,
    simulate=_simulate,
    needs_second_receiver=True,
    missing_noise=_missing_fdoa,
    description="frequency difference of arrival as the range-rate difference (m/s); Hz = value f_c / c",
)
