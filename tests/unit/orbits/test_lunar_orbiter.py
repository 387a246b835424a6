"""The lunar orbiter builder: the geometry of the papers' default orbiter, vis-viva, and a bound ten-day arc."""

import math

import numpy as np
import pytest

from liaison_cli.dynamics.constants import GM_MOON_KM3_S2, LU_KM, MU, TU_S, VU_KM_S
from liaison_cli.dynamics.integrators.dop853 import dop853_states
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.orbits.keplerian import elements_to_moon_inertial, keplerian_period_s
from tests.conftest import LUNAR


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
    states = dop853_states(LUNAR, np.linspace(0, 10 * 86400 / TU_S, 2000), MU)
    r = np.linalg.norm(states[:, :3] - np.array([1 - MU, 0, 0]), axis=1) * LU_KM
    assert 4000 < r.min() < 5600 and 11000 < r.max() < 14500
