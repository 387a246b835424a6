"""The link budget and the ranging error models (PN, telemetry, time-derived) against the paper's numbers."""

import math

import pytest

from liaison_cli.radio.link_budget import LinkLeg, db_to_linear
from liaison_cli.radio.ranging import (
    pn_chip_rate_bias_m,
    pn_ranging_sigma_m,
    sigma_from_link_budget,
    telemetry_ranging_sigma_m,
    time_derived_sigma_m,
)


TABLE2_UP = LinkLeg(60000, 2200, 3, 1, 25, 2000, 1, -21, 3)
TABLE2_DOWN = LinkLeg(60000, 2200, 3, 1, 9, 5000, 1, -1, 3)


def test_table2_link_budget_gives_the_papers_172_m():
    # Free-space loss at 60,000 km and 2.2 GHz, and both legs closing near Es/N0 = 2.75 dB.
    assert TABLE2_UP.free_space_loss_db == pytest.approx(194.85, abs=0.01)
    assert TABLE2_UP.es_over_n0_db == pytest.approx(2.73, abs=0.01)
    assert TABLE2_DOWN.es_over_n0_db == pytest.approx(2.75, abs=0.01)
    sigma = sigma_from_link_budget("time_derived", TABLE2_UP, TABLE2_DOWN, correlator_integration_s=0.3)
    assert sigma == pytest.approx(172.0, rel=0.02)


def test_lumio_rates_give_the_papers_680_m_with_eq4():
    # Assumption: the LUMIO link closes at the same operating point (Es/N0 = 2.75 dB) with T_l = 0.3 s.
    es = db_to_linear(2.75)
    sigma = time_derived_sigma_m(1 / 1000, 1 / 4000, 0.3, es)
    assert sigma == pytest.approx(680.0, rel=0.02)


def test_time_derived_reduces_to_eq4_when_both_legs_match():
    es = 2.0
    general = time_derived_sigma_m(1e-3, 2e-4, 0.5, es, es)
    eq4 = 4 * 299792458.0 * math.sqrt(1e-3**4 + 2e-4**4) / (math.pi * 0.5 * es)
    assert general == pytest.approx(eq4, rel=1e-12)


def test_pn_and_telemetry_clock_terms():
    # Eq. 1 with f_rc = 1 MHz, B_L = 1 Hz, P_RC/N0 = 30 dB-Hz: c / (4 sqrt(2) 1e6) / sqrt(1000).
    pn = pn_ranging_sigma_m(1e6, 1.0, 1000.0)
    assert pn == pytest.approx(299792458.0 / (4 * math.sqrt(2) * 1e6) / math.sqrt(1000.0), rel=1e-12)
    # Eq. 3's clock term is c/(8 f_rc) sqrt(B_L/(P_RC/N0)) = PN term / sqrt(2); its telemetry term
    # falls with the square of the symbol duration.
    tm_fast = telemetry_ranging_sigma_m(1e-5, 1.0, 10.0, 1e6, 1.0, 1000.0)
    tm_slow = telemetry_ranging_sigma_m(2e-5, 1.0, 10.0, 1e6, 1.0, 1000.0)
    clock = pn / math.sqrt(2)
    assert (tm_slow - clock) == pytest.approx(4 * (tm_fast - clock), rel=1e-9)
    # Eq. 2: 1 Hz chip-rate offset at 1 Mchip/s over 1 s.
    assert pn_chip_rate_bias_m(1e6, 1.0, 1.0) == pytest.approx(299792458.0 / 4e6, rel=1e-12)


def test_telemetry_ranging_beats_pn_at_high_rates_but_not_low():
    kwargs = dict(ranging_clock_hz=1e5, loop_bandwidth_hz=1.0, ranging_power_fraction_db=-10.0)
    fast = LinkLeg(60000, 2200, 3, 1, 9, 100_000, 1, -1, 3)
    slow = LinkLeg(60000, 2200, 3, 1, 9, 500, 1, -1, 3)
    pn = sigma_from_link_budget("pn", TABLE2_UP, fast, 0.3, **kwargs)
    assert sigma_from_link_budget("telemetry", TABLE2_UP, fast, 0.3, **kwargs) < pn
    assert sigma_from_link_budget("telemetry", TABLE2_UP, slow, 0.3, **kwargs) > pn
