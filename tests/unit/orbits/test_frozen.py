"""Elliptical frozen lunar orbits (orbits.frozen, `elements: {frozen: true}`): the orbit solved for stays frozen
when flown for two lunar months in the CRTBP, with the Moon's J2 and with its field to degree 8, while orbits 3
degrees off it turn their perilune by about as many degrees; the first-order average alone is not enough."""

import numpy as np
import pytest

from liaison_cli.dynamics.constants import MU, TU_S
from liaison_cli.dynamics.crtbp_field import crtbp_params, harmonics_term, j2_term
from liaison_cli.dynamics.integrators.rk8 import rk8_states_forced
from liaison_cli.dynamics.lunar_gravity import lunar_field, lunar_j2
from liaison_cli.orbits.frozen import (_arguments_of_perilune_deg, flown_argp_rate_deg_day, frozen_elements,
                                       frozen_inclination_deg, omega_rate_rad_s)
from liaison_cli.orbits.keplerian import lunar_orbiter_state_lu
from liaison_cli.scenario.participants import KeplerianElements

TWO_MONTHS_S = 55 * 86400.0


def _turn_over_two_months_deg(a_km, e, i_deg, params) -> float:
    """The change of the daily-mean argument of perilune from the first day to the last of 55 days."""
    times = np.arange(0.0, TWO_MONTHS_S + 1.0, 1800.0) / TU_S
    states = rk8_states_forced(lunar_orbiter_state_lu(a_km, e, i_deg, 0.0, 90.0, 0.0), times, 60.0 / TU_S, params,
                               np.zeros((len(times), 3)))
    daily = _arguments_of_perilune_deg(states, times)[:len(times) // 48 * 48].reshape(-1, 48).mean(axis=1)
    return float(daily[-1] - daily[0])


@pytest.mark.parametrize("field", ["j2", "degree 8"])
def test_the_solved_orbit_stays_frozen_and_its_neighbours_do_not(field):
    j2, radius_km = lunar_j2()
    a_km, e, i_deg = frozen_elements(j2, radius_km, 90.0, e=0.6, a_km=6142.0)
    params = crtbp_params(MU, j2_term(*lunar_j2()) if field == "j2" else harmonics_term(lunar_field(8)))
    frozen = _turn_over_two_months_deg(a_km, e, i_deg, params)
    neighbours = [_turn_over_two_months_deg(a_km, e, i_deg + d, params) for d in (-3.0, 3.0)]
    assert neighbours[0] > 2.0 and neighbours[1] < -2.0  # measured: +3.1 and -3.4 deg
    assert abs(frozen) < 0.1 * min(abs(n) for n in neighbours)  # measured: -0.20 (J2), -0.16 (degree 8)


def test_the_first_order_average_is_only_the_start():
    """The averaged rate's root turns its perilune by ~0.03 deg/day when flown; the refined one by < 1e-4."""
    j2, radius_km = lunar_j2()
    averaged = frozen_inclination_deg(6142.0, 0.6, j2, radius_km)
    assert omega_rate_rad_s(6142.0, 0.6, averaged, j2, radius_km) == pytest.approx(0.0, abs=1e-15)
    assert abs(flown_argp_rate_deg_day(6142.0, 0.6, averaged, 90.0, j2, radius_km)) > 0.01
    _, _, refined = frozen_elements(j2, radius_km, 90.0, e=0.6, a_km=6142.0)
    assert 0.5 < refined - averaged < 1.5  # measured: 0.86 deg
    assert abs(flown_argp_rate_deg_day(6142.0, 0.6, refined, 90.0, j2, radius_km)) < 1e-4


def test_the_elements_solve_either_e_or_i_and_refuse_what_cannot_be():
    by_e = KeplerianElements(a_km=6142.0, e=0.6, frozen=True)
    assert by_e.argument_of_perilune_deg == 90.0 and 53.0 < by_e.inclination_deg < 54.0
    by_i = KeplerianElements(a_km=6142.0, i_deg=by_e.inclination_deg, frozen=True)
    assert by_i.eccentricity == pytest.approx(0.6, abs=1e-4)  # the same orbit, solved the other way
    by_altitude = KeplerianElements(altitude_km=1000.0, e=0.7, argp_deg=270, frozen=True)
    assert by_altitude.semi_major_axis_km == pytest.approx((1737.4 + 1000.0) / 0.3)
    for bad, message in (({"a_km": 6142.0, "i_deg": 30.0}, "no eccentricity"),
                         ({"a_km": 6142.0, "e": 0.6, "argp_deg": 45}, "allowed: 90"),
                         ({"a_km": 6142.0, "e": 0.6, "i_deg": 50.0}, "give e or i_deg")):
        with pytest.raises(ValueError, match=message):
            KeplerianElements(frozen=True, **bad)
    with pytest.raises(ValueError, match="give e and i_deg"):
        KeplerianElements(a_km=6142.0, e=0.6)
