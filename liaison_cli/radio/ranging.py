"""Crosslink ranging error models (Turan et al. 2022, Eq. 1-4). All outputs in metres (1 sigma).

Symbols: c speed of light, f_rc ranging-clock frequency, B_L one-sided loop bandwidth, P_RC/N0
ranging-clock power to noise density (linear, Hz), T_l correlator integration time, Es/N0 symbol
energy to noise density (linear), T_sd channel symbol duration.
"""

import math

from liaison_cli.radio.carrier import (
    C_M_S,
    interferometer_path_sigma_m,
    loop_phase_sigma_rad,
    tone_ranging_sigma_m,
    two_way_doppler_sigma_m_s,
)
from liaison_cli.radio.link_budget import LinkLeg, db_to_linear


def pn_ranging_sigma_m(ranging_clock_hz, loop_bandwidth_hz, ranging_clock_power_to_n0_hz):
    """Eq. 1: non-coherent PN ranging between a mother and a daughter craft."""
    return (
        C_M_S
        / (math.sqrt(2.0) * 4.0 * ranging_clock_hz)
        * loop_phase_sigma_rad(loop_bandwidth_hz, ranging_clock_power_to_n0_hz)
    )


def pn_chip_rate_bias_m(chip_rate_hz, chip_rate_offset_hz, integration_time_s):
    """Eq. 2: range bias from a received/local chip-rate mismatch."""
    return C_M_S * chip_rate_offset_hz * integration_time_s / (4.0 * chip_rate_hz)


def telemetry_ranging_sigma_m(
    symbol_duration_s,
    correlator_integration_s,
    es_over_n0,
    ranging_clock_hz,
    loop_bandwidth_hz,
    ranging_clock_power_to_n0_hz,
):
    """Eq. 3: telemetry-based ranging (downlink timing from the telemetry stream, uplink clock)."""
    telemetry_term = (
        4.0 * C_M_S * symbol_duration_s**2 / (math.pi * correlator_integration_s * es_over_n0)
    )
    clock_term = (
        C_M_S
        / (8.0 * ranging_clock_hz)
        * loop_phase_sigma_rad(loop_bandwidth_hz, ranging_clock_power_to_n0_hz)
    )
    return telemetry_term + clock_term


def time_derived_sigma_m(
    uplink_symbol_s, downlink_symbol_s, correlator_integration_s, es_over_n0_up, es_over_n0_down=None
):
    """Eq. 4: time-derived ranging from exchanged time stamps measured in channel symbols.

    The paper assumes one Es/N0 for both legs; when the two legs differ each leg's term is weighted
    by its own Es/N0 (quadrature sum), which reduces to Eq. 4 exactly when they are equal.
    """
    if es_over_n0_down is None:
        es_over_n0_down = es_over_n0_up
    root = math.sqrt((uplink_symbol_s**2 / es_over_n0_up) ** 2 + (downlink_symbol_s**2 / es_over_n0_down) ** 2)
    return 4.0 * C_M_S * root / (math.pi * correlator_integration_s)


def sigma_from_link_budget(
    method: str,
    uplink: LinkLeg,
    downlink: LinkLeg,
    correlator_integration_s: float,
    ranging_clock_hz: float | None = None,
    loop_bandwidth_hz: float | None = None,
    ranging_power_fraction_db: float | None = None,
) -> float:
    """1-sigma range error of a crosslink from its two legs' link budgets.

    method: 'time_derived' (Eq. 4), 'telemetry' (Eq. 3), 'pn' (Eq. 1) or 'tone' (001 Eq. 62-63, the
    major tone at `ranging_clock_hz`). For the clock / tone terms the ranging power is the uplink C/N0
    (margin held back) plus `ranging_power_fraction_db`.
    """
    es_up = db_to_linear(uplink.es_over_n0_db)
    es_down = db_to_linear(downlink.es_over_n0_db)
    if method == "time_derived":
        return time_derived_sigma_m(
            uplink.symbol_duration_s, downlink.symbol_duration_s, correlator_integration_s, es_up, es_down
        )
    prc_n0 = db_to_linear(uplink.c_over_n0_dbhz - uplink.margin_db + ranging_power_fraction_db)
    if method == "telemetry":
        return telemetry_ranging_sigma_m(
            downlink.symbol_duration_s,
            correlator_integration_s,
            es_down,
            ranging_clock_hz,
            loop_bandwidth_hz,
            prc_n0,
        )
    if method == "pn":
        return pn_ranging_sigma_m(ranging_clock_hz, loop_bandwidth_hz, prc_n0)
    if method == "tone":
        return tone_ranging_sigma_m(ranging_clock_hz, loop_phase_sigma_rad(loop_bandwidth_hz, prc_n0))
    raise ValueError(f"unknown ranging method {method!r}")


def carrier_sigmas_from_link_budget(
    uplink: LinkLeg,
    downlink: LinkLeg,
    carrier_power_fraction_db: float,
    carrier_loop_bandwidth_hz: float,
    doppler_count_s: float,
    turnaround_ratio: float,
) -> dict:
    """Carrier-phase observables of a two-way coherent crosslink from its two legs' link budgets.

    The residual carrier of each leg carries its C/N0 (margin held back) plus `carrier_power_fraction_db`;
    both ends track it with a PLL of one-sided bandwidth `carrier_loop_bandwidth_hz`. Returns the loop
    SNRs, the Doppler range-rate sigma (001 Eq. 5, count time `doppler_count_s`) and the LOS path-
    difference sigma of a phase interferometer at the receiver, which sees the downlink (Eq. 9).
    """
    def carrier_power_to_n0_hz(leg):
        return db_to_linear(leg.c_over_n0_dbhz - leg.margin_db + carrier_power_fraction_db)

    rho_up = carrier_power_to_n0_hz(uplink) / carrier_loop_bandwidth_hz
    rho_down = carrier_power_to_n0_hz(downlink) / carrier_loop_bandwidth_hz
    downlink_hz = downlink.frequency_mhz * 1e6
    downlink_phase_rad = loop_phase_sigma_rad(carrier_loop_bandwidth_hz, carrier_power_to_n0_hz(downlink))
    return {
        "uplink_loop_snr": rho_up,
        "downlink_loop_snr": rho_down,
        "range_rate_sigma_m_s": two_way_doppler_sigma_m_s(downlink_hz, doppler_count_s, rho_down, rho_up,
                                                          turnaround_ratio),
        "los_path_sigma_m": interferometer_path_sigma_m(downlink_hz, downlink_phase_rad),
    }
