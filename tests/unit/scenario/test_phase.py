"""A spacecraft's `phase` moves it along its periodic orbit in the CRTBP as in the dated model (it used to be read
by the dated model only, so a CRTBP phase was silently ignored)."""

import numpy as np

from liaison_cli.orbits.family_store import member_state
from liaison_cli.dynamics.integrators.dop853 import dop853_states
from liaison_cli.dynamics.constants import MU
from liaison_cli.scenario.loading import validate_scenario
from liaison_cli.scenario.setup import prepare_problem


def _truth(phase):
    relay = {"name": "Relay", "orbit": "dro", "period_days": 8.0, **({"phase": phase} if phase else {})}
    data = {"name": "phase", "duration_days": 0.5, "spacecraft": [
        relay, {"name": "User", "orbit": "lunar_keplerian",
                "elements": {"a_km": 4000, "e": 0.0, "i_deg": 30, "raan_deg": 0, "argp_deg": 0, "ta_deg": 0}}],
        "links": [{"receiver": "Relay", "transponder": "User"}], "measurement": {"interval_s": 600},
        "noise": {"sigma_m": 10}, "monte_carlo": {"runs": 1, "seed": 1}}
    return prepare_problem(validate_scenario(data, "phase")).truth[:, :6]


def test_a_crtbp_phase_starts_the_spacecraft_that_far_along_its_orbit():
    member = member_state("dro", 8.0)
    quarter = dop853_states(np.array(member.state), np.array([0.0, 0.25 * member.period_tu]), MU)[-1]
    assert np.allclose(_truth(0.25)[0, :3], quarter[:3], atol=1e-8)  # LU: within ~4 m
    assert np.linalg.norm(_truth(0.25)[0, :3] - _truth(0.0)[0, :3]) > 0.01  # thousands of km apart


def test_a_spacecraft_that_does_not_change_is_flown_once_and_the_same():
    """scenario.truth.SPACECRAFT_CACHE (design candidates): the user's truth is reused, bit for bit, when only the
    relay changes; the relay's own truth is not."""
    from liaison_cli.scenario.truth import SPACECRAFT_CACHE

    def scenario(period):
        data = {"name": "cache", "duration_days": 0.5, "spacecraft": [
            {"name": "Relay", "orbit": "dro", "period_days": period},
            {"name": "User", "orbit": "lunar_keplerian",
             "elements": {"a_km": 4000, "e": 0.0, "i_deg": 30, "raan_deg": 0, "argp_deg": 0, "ta_deg": 0}}],
            "links": [{"receiver": "Relay", "transponder": "User"}], "measurement": {"interval_s": 600},
            "noise": {"sigma_m": 10}, "monte_carlo": {"runs": 1, "seed": 1}}
        return validate_scenario(data, "cache")

    flown = {}
    first = prepare_problem(scenario(8.0), {SPACECRAFT_CACHE: flown}).truth
    assert len(flown) == 2
    second = prepare_problem(scenario(9.0), {SPACECRAFT_CACHE: flown}).truth
    assert len(flown) == 3  # the new relay only
    alone = prepare_problem(scenario(9.0)).truth
    assert np.array_equal(second, alone) and np.array_equal(first[:, 6:], second[:, 6:])
    assert not np.array_equal(first[:, :6], second[:, :6])


def test_a_low_orbit_by_altitude_survives_a_round_trip_and_flies_where_a_km_would():
    """elements.altitude_km: the orbit a_km = (R + altitude) / (1 - e) gives; the scenario's own dump validates
    again (warm-up and overrides re-validate dumps: a filled-in a_km beside altitude_km was refused)."""
    from liaison_cli.dynamics.constants import MOON_RADIUS_KM

    def mapping(elements):
        return {"name": "low", "duration_days": 0.2, "spacecraft": [
            {"name": "Relay", "orbit": "dro", "period_days": 8.0},
            {"name": "User", "orbit": "lunar_keplerian", "elements": elements}],
            "links": [{"receiver": "Relay", "transponder": "User"}], "measurement": {"interval_s": 600},
            "noise": {"sigma_m": 10}, "monte_carlo": {"runs": 1, "seed": 1}}

    by_altitude = validate_scenario(mapping({"altitude_km": 100.0, "e": 0.1, "i_deg": 90}), "low")
    again = validate_scenario(by_altitude.model_dump(mode="json"), "low")
    by_a = validate_scenario(mapping({"a_km": (MOON_RADIUS_KM + 100.0) / 0.9, "e": 0.1, "i_deg": 90}), "low")
    assert again == by_altitude
    assert np.allclose(prepare_problem(by_altitude).truth, prepare_problem(by_a).truth, rtol=0, atol=1e-12)
