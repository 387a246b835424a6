"""The Moon's J2 alone as a CRTBP term (dynamics.zonal_j2, crtbp_field.TERM_J2), the second force added by
docs/architecture.md's checklist: its closed form against the Cunningham evaluator fed C20 alone, its gradient
against central differences, and a 100 km orbit's nodal regression against the textbook secular rate."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from liaison_cli.dynamics.constants import LU_KM, MU, TU_S
from liaison_cli.dynamics.crtbp_field import (TERM_HARMONICS, TERM_J2, added_terms_into, crtbp_params, field_derivative,
                                              harmonics_term, j2_term, term_payload)
from liaison_cli.dynamics.lunar_gravity import lunar_field, lunar_j2
from liaison_cli.dynamics.spherical_harmonics import acceleration_gradient_into, packed_index
from liaison_cli.dynamics.zonal_j2 import j2_acceleration_gradient_into
from liaison_cli.scenario.loading import validate_scenario

GM, RADIUS = 4902.8, 1738.0  # km^3/s^2, km


def _points(count=200, seed=3):
    rng = np.random.default_rng(seed)
    directions = rng.standard_normal((count, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    return directions * rng.uniform(1788.0, 20000.0, count)[:, None]


def test_the_closed_form_is_the_harmonic_evaluator_fed_c20_alone():
    j2 = 2.0323e-4
    size = packed_index(2, 2) + 1
    c, s = np.zeros(size), np.zeros(size)
    c[packed_index(2, 0)] = -j2 / np.sqrt(5.0)
    mine, theirs = (np.empty(3), np.empty(6)), (np.empty(3), np.empty(6))
    for p in _points():
        j2_acceleration_gradient_into(GM, j2, RADIUS, p[0], p[1], p[2], True, *mine)
        acceleration_gradient_into(c, s, GM, RADIUS, 2, p[0], p[1], p[2], True, *theirs)
        np.testing.assert_allclose(mine[0], theirs[0], rtol=1e-12, atol=1e-12 * np.abs(theirs[0]).max())
        np.testing.assert_allclose(mine[1], theirs[1], rtol=1e-11, atol=1e-11 * np.abs(theirs[1]).max())


def test_the_gradient_is_the_accelerations_central_difference_and_traceless():
    acc, grad, plus, minus, unused = np.empty(3), np.empty(6), np.empty(3), np.empty(3), np.empty(6)
    where = {(0, 0): 0, (1, 1): 1, (2, 2): 2, (0, 1): 3, (0, 2): 4, (1, 2): 5}
    for p in _points(50):
        j2_acceleration_gradient_into(GM, 2e-4, RADIUS, p[0], p[1], p[2], True, acc, grad)
        assert abs(grad[0] + grad[1] + grad[2]) < 1e-12 * np.abs(grad).max()
        for j in range(3):
            h = np.zeros(3)
            h[j] = 1e-3
            j2_acceleration_gradient_into(GM, 2e-4, RADIUS, *(p + h), False, plus, unused)
            j2_acceleration_gradient_into(GM, 2e-4, RADIUS, *(p - h), False, minus, unused)
            numeric = (plus - minus) / 2e-3
            for i in range(3):
                assert grad[where[tuple(sorted((i, j)))]] == pytest.approx(numeric[i], rel=1e-6,
                                                                         abs=1e-8 * np.abs(grad).max())


def _node_rad(states, times_tu):
    """The Moon-centred inertial ascending node of rotating-frame states (the frame turns at 1 rad/TU)."""
    out = []
    for state, t in zip(states, times_tu):
        r = state[:3] - np.array([1.0 - MU, 0.0, 0.0])
        v = state[3:] + np.cross([0.0, 0.0, 1.0], state[:3]) - np.cross([0.0, 0.0, 1.0], [1.0 - MU, 0.0, 0.0])
        c, s = np.cos(t), np.sin(t)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        h = np.cross(turn @ r, turn @ v)
        out.append(np.arctan2(h[0], -h[1]))
    return np.unwrap(out)


def test_a_low_orbit_regresses_its_node_at_the_textbook_rate():
    """dOmega/dt = -3/2 n J2 (R/p)^2 cos i (secular, first order in J2): the node's drift with the J2 term minus
    its drift without (the Earth's pull on the node is the same in both) over two days, fitted by a line through
    samples every minute (the short-period terms average out), within 0.5 % (measured: 0.15 %)."""
    j2_params = crtbp_params(MU, j2_term(*lunar_j2()))
    j2, radius_lu = term_payload(j2_params, TERM_J2)[:2]
    a_lu, inclination = (1737.4 + 100.0) / LU_KM, np.radians(60.0)
    speed = np.sqrt(MU / a_lu)
    r0 = np.array([1.0 - MU + a_lu, 0.0, 0.0])
    v_inertial = np.array([0.0, speed * np.cos(inclination), speed * np.sin(inclination)])
    x0 = np.concatenate([r0, v_inertial - np.cross([0.0, 0.0, 1.0], r0) + np.cross([0.0, 0.0, 1.0], [1.0 - MU, 0, 0])])
    times = np.linspace(0.0, 2 * 86400.0 / TU_S, 2881)
    drift = []
    for params in (j2_params, np.array([MU])):
        orbit = solve_ivp(lambda t, y, p=params: field_derivative(y, p), (0.0, times[-1]), x0, method="DOP853",
                          rtol=1e-11, atol=1e-13, t_eval=times)
        drift.append(np.polyfit(times, _node_rad(orbit.y.T, times), 1)[0])
    n = np.sqrt(MU / a_lu**3)
    textbook = -1.5 * n * j2 * (radius_lu / a_lu) ** 2 * np.cos(inclination)
    assert drift[0] - drift[1] == pytest.approx(textbook, rel=0.005)


def test_terms_add_and_the_scenario_key_asks_for_j2():
    x, y, z = 1.0 - MU + 1900.0 / LU_KM, 300.0 / LU_KM, 500.0 / LU_KM
    field = lunar_field(8)
    both = crtbp_params(MU, harmonics_term(field), j2_term(*lunar_j2()))
    one, other, total, grad = np.empty(3), np.empty(3), np.empty(3), np.empty(6)
    added_terms_into(crtbp_params(MU, harmonics_term(field)), x, y, z, False, one, grad)
    added_terms_into(crtbp_params(MU, j2_term(*lunar_j2())), x, y, z, False, other, grad)
    added_terms_into(both, x, y, z, False, total, grad)
    np.testing.assert_allclose(total, one + other, rtol=1e-14)
    assert term_payload(both, TERM_HARMONICS)[0] == 8

    from liaison_cli.scenario.setup import prepare_problem
    from liaison_cli.scenario.truth import dynamics_model

    mapping = {"name": "j2_filter", "duration_days": 0.5,
               "spacecraft": [{"name": "DRO", "orbit": "dro", "period_days": 14.0},
                              {"name": "LLO", "orbit": "lunar_keplerian",
                               "elements": {"altitude_km": 100.0, "e": 0.0, "i_deg": 90}}],
               "links": [{"receiver": "DRO", "transponder": "LLO"}], "measurement": {"interval_s": 60},
               "noise": {"sigma_m": 5.0}, "monte_carlo": {"runs": 1, "seed": 1},
               "moon_gravity": {"degree": 8, "filter_field": "j2"}}
    scenario = validate_scenario(mapping, "j2.yaml")
    model = dynamics_model(scenario)
    assert term_payload(model.filter_params, TERM_J2) is not None and term_payload(model.params, TERM_J2) is None
    parts = prepare_problem(scenario).default_noises["LLO"].parts
    assert "lunar field beyond J2" in parts
    with pytest.raises(Exception, match="filter_field: j2"):
        validate_scenario({**mapping, "moon_gravity": {"degree": 8, "filter_field": "j2", "filter_degree": 2}}, "x")
