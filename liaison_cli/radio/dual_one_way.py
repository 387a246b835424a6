"""Error models of dual one-way ranging receivers (002 Eq. 8-12): code (DLL) and carrier (PLL) tracking.

- Cramér-Rao bounds (002 Eq. 8-10, after Poisel): sigma_TOA >= 1 / (beta sqrt(2 E/N0)) with beta the Gabor
  (RMS angular) bandwidth of the received signal, and sigma_FOA >= 1 / (alpha sqrt(2 E/N0)) in rad/s with
  alpha the effective duration (RMS of 2 pi t); by the time-frequency duality this bound is in Hz (cycles/s),
  as the TOA bound with beta in rad/s is in seconds (checked against simulated ML estimators in
  tests/unit/radio/test_dual_one_way_radio.py). E/N0 = C/N0 * T for a coherent integration of T seconds.
  For a BPSK spreading code of chip period Tc the power spectrum is Tc sinc^2(f Tc), cut by the front-end
  filter at +-B_fe/2; beta is integrated numerically. A constant-envelope signal of duration T has
  alpha = pi T / sqrt(3).
- DLL thermal noise with a coherent early-minus-late discriminator (002 Eq. 11, the Betz / Kaplan-Hegarty
  form): three regimes of the early-late spacing D (in chips) against Rc / B_fe and pi Rc / B_fe.
- PLL range-rate noise (002 Eq. 12, after Sokolova): sigma = lambda / (2 pi T) sqrt(B_d / (C/N0) (1 + 1 / (2 T
  C/N0))), B_d the loop's Doppler bandwidth.

Units in names; C/N0 enters in dB-Hz and is converted once.
"""

import math
from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import SPEED_OF_LIGHT_M_S


DLL_WIDE = "wide (D >= pi Rc/B_fe)"
DLL_NARROW = "narrow (Rc/B_fe < D < pi Rc/B_fe)"
DLL_VERY_NARROW = "very narrow (D <= Rc/B_fe)"


def c_n0_ratio(c_n0_db_hz: float) -> float:
    """C/N0 from dB-Hz to Hz."""
    return 10.0 ** (c_n0_db_hz / 10.0)


def gabor_bandwidth_bpsk_rad_s(chip_rate_hz: float, front_end_bandwidth_hz: float, samples: int = 200_001) -> float:
    """beta (rad/s) of a BPSK code, |S(f)|^2 = Tc sinc^2(f Tc), within the two-sided front-end band B_fe."""
    chip_s = 1.0 / chip_rate_hz
    f = np.linspace(-front_end_bandwidth_hz / 2.0, front_end_bandwidth_hz / 2.0, samples)
    power = chip_s * np.sinc(f * chip_s) ** 2  # numpy sinc is sin(pi x) / (pi x)
    return float(np.sqrt(np.trapezoid((2.0 * np.pi * f) ** 2 * power, f) / np.trapezoid(power, f)))


def effective_duration_rect_s(duration_s: float) -> float:
    """alpha (s) of a constant-envelope signal lasting duration_s: sqrt of the mean (2 pi t)^2, t centred."""
    return math.pi * duration_s / math.sqrt(3.0)


def toa_crb_s(gabor_bandwidth_rad_s: float, c_n0_db_hz: float, integration_s: float) -> float:
    """002 Eq. 8: the time-of-arrival Cramér-Rao bound (s)."""
    return 1.0 / (gabor_bandwidth_rad_s * math.sqrt(2.0 * c_n0_ratio(c_n0_db_hz) * integration_s))


def foa_crb_hz(effective_duration_s: float, c_n0_db_hz: float, integration_s: float) -> float:
    """002 Eq. 10: the frequency-of-arrival Cramér-Rao bound (Hz), alpha the RMS of 2 pi t (s)."""
    return 1.0 / (effective_duration_s * math.sqrt(2.0 * c_n0_ratio(c_n0_db_hz) * integration_s))


def dll_regime(spacing_chips: float, chip_rate_hz: float, front_end_bandwidth_hz: float) -> str:
    ratio = chip_rate_hz / front_end_bandwidth_hz
    if spacing_chips >= math.pi * ratio:
        return DLL_WIDE
    if spacing_chips > ratio:
        return DLL_NARROW
    return DLL_VERY_NARROW


def dll_sigma_chips(c_n0_db_hz: float, code_loop_bandwidth_hz: float, integration_s: float, chip_rate_hz: float,
                    front_end_bandwidth_hz: float, spacing_chips: float) -> float:
    """002 Eq. 11: DLL code-tracking 1-sigma in chips, coherent early-minus-late power discriminator."""
    cn0 = c_n0_ratio(c_n0_db_hz)
    d = spacing_chips
    b_tc = front_end_bandwidth_hz / chip_rate_hz  # B_fe * Tc
    base = code_loop_bandwidth_hz / (2.0 * cn0)
    regime = dll_regime(d, chip_rate_hz, front_end_bandwidth_hz)
    if regime == DLL_WIDE:
        variance = base * d * (1.0 + 2.0 / (integration_s * cn0 * (2.0 - d)))
    elif regime == DLL_NARROW:
        variance = base * (1.0 / b_tc + b_tc / (math.pi - 1.0) * (d - 1.0 / b_tc) ** 2) * (
            1.0 + 2.0 / (integration_s * cn0 * (2.0 - d)))
    else:
        variance = base / b_tc * (1.0 + 1.0 / (integration_s * cn0))
    return math.sqrt(variance)


def pll_range_rate_sigma_m_s(carrier_frequency_hz: float, c_n0_db_hz: float, doppler_bandwidth_hz: float,
                             integration_s: float) -> float:
    """002 Eq. 12: range-rate 1-sigma (m/s) of PLL Doppler estimates with Doppler bandwidth B_d."""
    cn0 = c_n0_ratio(c_n0_db_hz)
    wavelength_m = SPEED_OF_LIGHT_M_S / carrier_frequency_hz
    return wavelength_m / (2.0 * math.pi * integration_s) * math.sqrt(
        doppler_bandwidth_hz / cn0 * (1.0 + 1.0 / (2.0 * integration_s * cn0)))


@dataclass(frozen=True)
class DualOneWayReceiver:
    """The parameters of a dual one-way ranging receiver (002 §2): carrier, C/N0, code and carrier loops."""

    carrier_frequency_hz: float
    c_n0_db_hz: float
    code_loop_bandwidth_hz: float  # B_n
    code_integration_s: float  # T_int of the DLL
    front_end_bandwidth_hz: float  # two-sided B_fe
    chip_rate_hz: float  # R_c
    correlator_spacing_s: float  # D, early-to-late
    doppler_bandwidth_hz: float  # B_d of the PLL
    carrier_integration_s: float  # T_int of the PLL

    @property
    def spacing_chips(self) -> float:
        return self.correlator_spacing_s * self.chip_rate_hz

    def sigmas(self) -> dict:
        """Every model's 1-sigma in range (m) and range-rate (m/s) units, plus the DLL regime."""
        chip_m = SPEED_OF_LIGHT_M_S / self.chip_rate_hz
        beta = gabor_bandwidth_bpsk_rad_s(self.chip_rate_hz, self.front_end_bandwidth_hz)
        wavelength_m = SPEED_OF_LIGHT_M_S / self.carrier_frequency_hz
        alpha = effective_duration_rect_s(self.carrier_integration_s)
        return {
            "gabor_bandwidth_hz": beta / (2.0 * math.pi),
            "toa_crb_range_m": SPEED_OF_LIGHT_M_S * toa_crb_s(beta, self.c_n0_db_hz, self.code_integration_s),
            "dll_regime": dll_regime(self.spacing_chips, self.chip_rate_hz, self.front_end_bandwidth_hz),
            "dll_range_m": chip_m * dll_sigma_chips(self.c_n0_db_hz, self.code_loop_bandwidth_hz,
                                                    self.code_integration_s, self.chip_rate_hz,
                                                    self.front_end_bandwidth_hz, self.spacing_chips),
            "foa_crb_range_rate_m_s": wavelength_m * foa_crb_hz(alpha, self.c_n0_db_hz, self.carrier_integration_s),
            "pll_range_rate_m_s": pll_range_rate_sigma_m_s(self.carrier_frequency_hz, self.c_n0_db_hz,
                                                           self.doppler_bandwidth_hz, self.carrier_integration_s),
        }
