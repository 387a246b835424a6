"""Lunar orbiter builder and the link budget / ranging error models against the paper's numbers."""

import math

import numpy as np
import pytest

from liaison_cli.dynamics.constants import GM_MOON_KM3_S2, LU_KM, MU, TU_S, VU_KM_S
from liaison_cli.dynamics.propagation import propagate_states
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.orbits.keplerian import elements_to_moon_inertial, keplerian_period_s, lunar_orbiter_state_lu
from liaison_cli.radio.link_budget import LinkLeg, db_to_linear
from liaison_cli.radio.ranging import (
    pn_chip_rate_bias_m,
    pn_ranging_sigma_m,
    sigma_from_link_budget,
    telemetry_ranging_sigma_m,
    time_derived_sigma_m,
)

LUNAR = lunar_orbiter_state_lu(9000.0, 0.4, 60.0, 0.0, 0.0, 0.0)


def test_default_lunar_orbiter_geometry_matches_the_issue():
    assert keplerian_period_s(9000.0) / 3600.0 == pytest.approx(21.3, abs=0.1)
    to_eml2 = np.linalg.norm(LUNAR[:3] - CATALOG["eml2_halo"].state()[:3]) * LU_KM
    to_eml1 = np.linalg.norm(LUNAR[:3] - CATALOG["eml1_halo"].state()[:3]) * LU_KM
    halos = np.linalg.norm(CATALOG["eml2_halo"].state()[:3] - CATALOG["eml1_halo"].state()[:3]) * LU_KM
    assert to_eml2 == pytest.approx(70_300, abs=300)
    assert to_eml1 == pytest.approx(55_300, abs=300)
    assert halos == pytest.approx(125_600, abs=300)


def test_perilune_state_obeys_vis_viva_and_the_frame_rotation():
    r_km, v_km_s = elements_to_moon_inertial(9000.0, 0.4, 60.0, 0.0, 0.0, 0.0)
    assert np.linalg.norm(r_km) == pytest.approx(5400.0)
    assert np.linalg.norm(v_km_s) == pytest.approx(math.sqrt(GM_MOON_KM3_S2 * (2 / 5400.0 - 1 / 9000.0)))
    rel_lu = LUNAR[:3] - np.array([1 - MU, 0, 0])
    v_inertial = LUNAR[3:] + np.cross([0, 0, 1.0], rel_lu)
    assert np.allclose(v_inertial * VU_KM_S, v_km_s, atol=1e-12)


def test_lunar_orbiter_stays_bound_for_ten_days_in_the_crtbp():
    states = propagate_states(LUNAR, np.linspace(0, 10 * 86400 / TU_S, 2000), MU)
    r = np.linalg.norm(states[:, :3] - np.array([1 - MU, 0, 0]), axis=1) * LU_KM
    assert 4000 < r.min() < 5600 and 11000 < r.max() < 14500


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
