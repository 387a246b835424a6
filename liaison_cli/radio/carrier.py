"""Phase-tracking error models: tone ranging, two-way Doppler, phase-interferometric LOS (001 §3, §5.4).

The seed text of 001 lost the equations (Eq. 5, 8-9, 62-65), so they are rebuilt here from the
linear phase-locked-loop model they rest on, with every convention stated:

* Loop phase jitter (Eq. 62): a PLL of one-sided noise bandwidth B_L tracking a component of power P in
  noise density N0 has sigma_phi^2 = B_L / (P/N0) = 1 / rho_L (rho_L the loop SNR; valid for rho_L >> 1).
  A two-sided ("bi-lateral") bandwidth W corresponds to B_L = W / 2.
* Tone ranging (Eq. 63): the major tone f_tone comes back delayed by the two-way light time 2 rho / c,
  so its phase is 4 pi f_tone rho / c and sigma_rho = lambda_tone sigma_phi / (4 pi).
* Doppler (Eq. 64): range-rate from the carrier phase counted over T: the two-way Doppler shift is
  2 rho_dot f_dn / c, the count differences two independent phase errors (sqrt(2) sigma_phi), so
  sigma_rho_dot = c sqrt(2) sigma_phi / (4 pi f_dn T) with f_dn = M f_T the downlink carrier.
* Two-way coherent Doppler thermal noise (Eq. 5, DSN 810-005 module 202 form): the transponder's loop
  jitter on the uplink is multiplied by the turnaround ratio G and rides on the downlink:
  sigma_phi^2 = 1/rho_dn + G^2/rho_up, hence sigma_rho_dot = c / (2 sqrt(2) pi f_dn T) sqrt(...).
* Phase-interferometric LOS (Eq. 9): the path difference across two antennas is lambda dphi / (2 pi);
  each antenna's phase carries its own thermal jitter (the transponded noise is common to both and
  cancels), so sigma_path = lambda sqrt(2) sigma_phi / (2 pi).

All frequencies in Hz, powers-to-noise-density linear in Hz (not dB-Hz), outputs in m, m/s or s.
"""

import math

from liaison_cli.dynamics.constants import SPEED_OF_LIGHT_M_S

C_M_S = SPEED_OF_LIGHT_M_S  # the short name of this module's formulas
TURNAROUND_S_BAND = 240.0 / 221.0  # S-band coherent transponder ratio (downlink / uplink carrier)


def loop_phase_sigma_rad(loop_bandwidth_hz: float, power_to_n0_hz: float) -> float:
    """Eq. 62: 1-sigma phase jitter of a linear PLL, sqrt(B_L / (P/N0)), B_L one-sided."""
    return math.sqrt(loop_bandwidth_hz / power_to_n0_hz)


def tone_ranging_sigma_m(tone_hz: float, phase_sigma_rad: float) -> float:
    """Eq. 63: two-way range error from the phase error on the major ranging tone."""
    return C_M_S * phase_sigma_rad / (4.0 * math.pi * tone_hz)


def doppler_range_rate_sigma_m_s(phase_sigma_rad: float, transmit_hz: float, turnaround_ratio: float,
                                 count_time_s: float) -> float:
    """Eq. 64: two-way range-rate error from carrier phase noise over a Doppler count of T seconds."""
    downlink_hz = turnaround_ratio * transmit_hz
    return C_M_S * math.sqrt(2.0) * phase_sigma_rad / (4.0 * math.pi * downlink_hz * count_time_s)


def two_way_doppler_phase_sigma_rad(downlink_loop_snr: float, uplink_loop_snr: float,
                                    turnaround_ratio: float) -> float:
    """Carrier phase jitter of a coherent two-way link: the receiver's own plus G times the transponder's."""
    return math.sqrt(1.0 / downlink_loop_snr + turnaround_ratio**2 / uplink_loop_snr)


def two_way_doppler_sigma_m_s(downlink_hz: float, count_time_s: float, downlink_loop_snr: float,
                              uplink_loop_snr: float, turnaround_ratio: float) -> float:
    """Eq. 5: thermal-noise range-rate error of a two-way coherent Doppler link."""
    phase = two_way_doppler_phase_sigma_rad(downlink_loop_snr, uplink_loop_snr, turnaround_ratio)
    return C_M_S * phase / (2.0 * math.sqrt(2.0) * math.pi * downlink_hz * count_time_s)


def interferometer_path_sigma_m(carrier_hz: float, phase_sigma_rad: float) -> float:
    """Eq. 9: path-difference error of a two-antenna phase interferometer (independent antenna noise)."""
    wavelength_m = C_M_S / carrier_hz
    return wavelength_m * math.sqrt(2.0) * phase_sigma_rad / (2.0 * math.pi)


def range_to_range_rate_ratio_s(tone_hz: float, downlink_hz: float, count_time_s: float,
                                tone_phase_sigma_rad: float = 1.0, carrier_phase_sigma_rad: float = 1.0) -> float:
    """Eq. 65: sigma_rho / sigma_rho_dot (seconds) of one ranging/Doppler unit.

    Eq. 63 over Eq. 64: (f_dn T) / (sqrt(2) f_tone) times the ratio of the two phase errors (1 when the
    tone and the carrier are tracked equally well, the case 001 quotes).
    """
    return downlink_hz * count_time_s * tone_phase_sigma_rad / (math.sqrt(2.0) * tone_hz * carrier_phase_sigma_rad)
