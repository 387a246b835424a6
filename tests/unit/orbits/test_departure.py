"""003 item 3 (departures): Lambert arcs that close, the departure hyperbola's geometry against two-body
motion, the three missions' derived launch targets, and departure bad input as one line."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.conftest import assert_one_line_error, edited_scenario, run_cli_in_process
from liaison_cli.dynamics.ephemeris import GM_KM3_S2
from liaison_cli.orbits.departure import asymptote_angles_deg, asymptote_unit, departure_state_km
from liaison_cli.orbits.departure_missions import DEPARTURE_MISSIONS, _heliocentric, derived_launch_targets
from liaison_cli.orbits.lambert import lambert

GM_SUN = GM_KM3_S2[10]
GM_EARTH = GM_KM3_S2[399]


def _two_body(state, duration_s, gm):
    sol = solve_ivp(lambda t, y: np.r_[y[3:], -gm * y[:3] / np.linalg.norm(y[:3]) ** 3], (0.0, duration_s), state,
                    method="DOP853", rtol=1e-12, atol=1e-9)
    return sol.y[:, -1]


@pytest.mark.parametrize("days,r2", [(20.0, (-1.0e8, 1.6e8, 1e6)), (150.0, (-1.0e8, 1.6e8, 1e6)),
                                     (250.0, (-2.0e8, -0.5e8, 3e6)), (90.0, (0.2e8, 1.1e8, -2e6))])
def test_lambert_arc_reaches_its_target(days, r2):
    """Short- and long-way arcs (elliptic and hyperbolic): two-body propagation from (r1, v1) ends at r2
    within 10 m after up to 250 days, with v2."""
    r1 = np.array([1.5e8, 0.0, 0.0])
    v1, v2 = lambert(r1, r2, days * 86400.0, GM_SUN)
    end = _two_body(np.r_[r1, v1], days * 86400.0, GM_SUN)
    assert np.linalg.norm(end[:3] - r2) < 0.01
    assert np.linalg.norm(end[3:] - v2) < 1e-8
    assert np.cross(r1, end[:3])[2] * np.cross(r1, v1)[2] >= 0 or days > 100  # prograde sense kept


def test_departure_hyperbola_geometry():
    """At periapsis: r = r_p and r . v = 0; energy C3 / 2 throughout; the orbit plane has the asked
    inclination; two weeks of two-body motion turn the velocity onto the asymptote (within 0.3 deg)."""
    c3, dla, rla, rp, inc = 12.0, -20.0, 150.0, 6563.0, 28.5
    at_periapsis = departure_state_km(c3, dla, rla, rp, 0.0, inc)
    assert np.linalg.norm(at_periapsis[:3]) == pytest.approx(rp, rel=1e-12)
    assert abs(at_periapsis[:3] @ at_periapsis[3:]) < 1e-9 * rp
    later = departure_state_km(c3, dla, rla, rp, 3600.0, inc)
    for state in (at_periapsis, later):
        energy = 0.5 * state[3:] @ state[3:] - GM_EARTH / np.linalg.norm(state[:3])
        assert 2.0 * energy == pytest.approx(c3, rel=1e-10)
    h = np.cross(later[:3], later[3:])
    assert np.degrees(np.arccos(h[2] / np.linalg.norm(h))) == pytest.approx(inc, abs=1e-9)
    # Kepler's equation: propagating the periapsis state an hour gives the state at one hour.
    assert np.linalg.norm(_two_body(at_periapsis, 3600.0, GM_EARTH)[:3] - later[:3]) < 1e-4
    far = _two_body(at_periapsis, 14 * 86400.0, GM_EARTH)
    angle = np.degrees(np.arccos(far[3:] @ asymptote_unit(dla, rla) / np.linalg.norm(far[3:])))
    assert angle < 0.3
    c3_far, dla_far, rla_far = asymptote_angles_deg(far[3:])
    assert abs(dla_far - dla) < 0.3 and abs(rla_far - rla) < 0.3


def test_the_hyperbola_refuses_an_impossible_plane_and_a_bound_orbit():
    with pytest.raises(ValueError, match="inclination"):
        departure_state_km(10.0, 40.0, 0.0, 6563.0, 0.0, 28.5)
    with pytest.raises(ValueError, match="C3"):
        departure_state_km(-1.0, 0.0, 0.0, 6563.0, 0.0, 28.5)


@pytest.mark.parametrize("name", sorted(DEPARTURE_MISSIONS))
def test_mission_targets_reach_the_first_encounter(name):
    """The derived asymptote, added to the Earth's heliocentric velocity at injection and flown about the
    Sun alone, reaches the target system's DE421 position at the published encounter date (within 1 km
    over 6-8 months: the Lambert solve), with a C3 of an interplanetary launch (5-25 km^2/s^2)."""
    from datetime import timedelta

    from liaison_cli.dynamics.timescales import utc_to_tdb_seconds
    from liaison_cli.orbits.departure_missions import _utc

    mission = DEPARTURE_MISSIONS[name]
    c3, dla, rla = derived_launch_targets(mission)
    assert 5.0 < c3 < 25.0
    t0 = utc_to_tdb_seconds(_utc(mission.start_utc) - timedelta(seconds=mission.time_from_periapsis_s()))
    t1 = utc_to_tdb_seconds(_utc(mission.encounter_utc))
    earth = _heliocentric(399, t0)
    v_inf = np.sqrt(c3) * asymptote_unit(dla, rla)
    end = _two_body(np.r_[earth[:3], earth[3:] + v_inf], t1 - t0, GM_SUN)
    assert np.linalg.norm(end[:3] - _heliocentric(mission.target_body, t1)[:3]) < 1.0


def test_a_departure_scenario_starts_on_its_hyperbola():
    """scenarios/003/msl.yaml: MSL's first state is the derived hyperbola 372.4 s after periapsis."""
    from liaison_cli.dynamics.ephemeris_model import SCALE
    from liaison_cli.scenario.dated import dated_initial_state_lu, dated_model
    from liaison_cli.scenario.loading import load_scenario

    from tests.conftest import SCENARIOS

    scenario, _ = load_scenario(SCENARIOS / "003" / "msl.yaml")
    msl = next(sc for sc in scenario.spacecraft if sc.name == "MSL")
    state = dated_initial_state_lu(msl, scenario, dated_model(scenario)) * SCALE
    c3, _, _ = derived_launch_targets(DEPARTURE_MISSIONS["msl"])
    energy = 0.5 * state[3:] @ state[3:] - GM_EARTH / np.linalg.norm(state[:3])
    assert 2.0 * energy == pytest.approx(c3, rel=1e-9)
    assert 6563.0 < np.linalg.norm(state[:3]) < 12000.0  # minutes after a 185 km periapsis


@pytest.mark.parametrize("old,new,fragments", [
    ("departure: {mission: msl}", "departure: {c3_km2_s2: -2.0, dla_deg: 5, rla_deg: 120}",
     ["c3_km2_s2", "C3 = -2", "C3 > 0"]),
    ("departure: {mission: msl}", "departure: {mission: voyager}", ["mission", "'voyager'", "cassini, mer_a, msl"]),
    ("departure: {mission: msl}", "departure: {mission: msl, c3_km2_s2: 9}", ["derives c3_km2_s2"]),
    ("departure: {mission: msl}", "departure: {c3_km2_s2: 9, dla_deg: 5}", ["all of c3_km2_s2, dla_deg and rla_deg"]),
    ("{name: Madrid, site: madrid,", "{name: Madrid, site: robledo,", ["site", "'robledo'", "goldstone, madrid"]),
    ("station_priority: [Goldstone, Madrid, Canberra]", "station_priority: [Goldstone, Usuda]",
     ["station_priority[1]", "'Usuda'", "not a ground station"]),
    ('epoch_utc: "2011-11-26T15:52:12.383"', 'epoch_utc: "2011-11-26T15:00:00"', ["msl", "before its injection"]),
])
def test_bad_departure_and_dsn_input_is_one_line(tmp_path, old, new, fragments):
    path = edited_scenario(tmp_path, "003/msl.yaml", old, new)
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, fragments)


def test_a_dsn_site_in_the_crtbp_is_one_line(tmp_path):
    """CRTBP stations take a longitude from the Earth-Moon line: a true-longitude site makes no sense there."""
    path = edited_scenario(tmp_path, "nrho_earth_station.yaml",
                           "{name: Canberra, latitude_deg: -35.4014, longitude_deg: 0.0, altitude_m: 680,",
                           "{name: Canberra, site: canberra,")
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, ["ground_stations[0].site", "dynamics: ephemeris"])
