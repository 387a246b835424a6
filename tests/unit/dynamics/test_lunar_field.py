"""The Moon's GRGM1200A field in the CRTBP (dynamics.lunar_gravity, dynamics.crtbp_field) against physics: the
file read as published, a Jacobi integral that still holds (the field turns with the rotating frame, so the
problem stays autonomous), the filter's STM against finite differences of its own propagation, a point-mass
parameter vector that leaves every number as it was, and the scenario keys that ask for it."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from liaison_cli.dynamics.constants import LU_KM, MU, TU_S
from liaison_cli.dynamics.crtbp import derivative, jacobi_constant
from liaison_cli.dynamics.crtbp_field import (added_terms_into, added_terms_scratch_into, crtbp_params, field_degree,
                                              field_derivative, harmonics_term, j2_term, moon_harmonics_into,
                                              terms_scratch_size)
from liaison_cli.dynamics.integrators.rk4 import rk4_state_stm
from liaison_cli.dynamics.lunar_gravity import lunar_field, lunar_j2
from liaison_cli.dynamics.spherical_harmonics import packed_index, potential
from liaison_cli.scenario.loading import validate_scenario


def low_orbit_state(altitude_km=100.0, inclination_deg=90.0):
    """A circular lunar orbit's rotating-frame state (LU, LU/TU) over the Moon's pole-to-pole plane."""
    r = (1737.4 + altitude_km) / LU_KM
    v = np.sqrt(MU / r)
    i = np.radians(inclination_deg)
    return np.array([1.0 - MU + r, 0.0, 0.0, 0.0, v * np.cos(i) - r, v * np.sin(i)])  # inertial v minus omega x r


def field_jacobi(state, field):
    """C = 2 (U_CRTBP + U_field) - v^2: the field is fixed in the rotating frame, so C is an integral of motion. The
    potential from the field's own coefficients (the propagators carry weight tables, not the coefficients)."""
    pa = np.array([1.0 - MU - state[0], -state[1], state[2]])
    return jacobi_constant(state, MU) + 2.0 * potential(field.c, field.s, MU, field.radius_km / LU_KM, field.degree, pa)


def test_grgm1200a_is_read_as_published():
    field = lunar_field(20)
    assert field.radius_km == 1738.0 and abs(field.gm_km3_s2 - 4902.80012) < 1e-4
    j2 = -np.sqrt(5.0) * field.c[packed_index(2, 0)]
    assert abs(j2 - 2.0323e-4) < 1e-7  # the Moon's J2 (GRAIL)
    c22 = field.c[packed_index(2, 2)]
    assert 3.46e-5 < c22 < 3.47e-5 and field.c[0] == field.c[1] == field.c[2] == 0.0  # no central term
    with pytest.raises(ValueError, match="allowed 2..1200"):
        lunar_field(1)


def test_the_field_keeps_the_jacobi_integral():
    field = lunar_field(20)
    params = crtbp_params(MU, harmonics_term(field))
    x0 = low_orbit_state()
    span = 0.5 * 86400.0 / TU_S
    orbit = solve_ivp(lambda t, y: field_derivative(y, params), (0.0, span), x0, method="DOP853", rtol=1e-12,
                      atol=1e-14, dense_output=False, t_eval=np.linspace(0.0, span, 40))
    c = np.array([field_jacobi(s, field) for s in orbit.y.T])
    assert np.ptp(c) < 1e-10 * abs(c[0])
    point_mass = np.array([jacobi_constant(s, MU) for s in orbit.y.T])
    assert np.ptp(point_mass) > 100 * np.ptp(c)  # ... which the point-mass integral alone is not


def test_the_field_moves_a_100_km_orbit_by_kilometres_in_a_day():
    x0 = low_orbit_state()
    span = 86400.0 / TU_S
    ends = [solve_ivp(lambda t, y, p=p: field_derivative(y, p), (0.0, span), x0, method="DOP853", rtol=1e-12,
                      atol=1e-14).y[:3, -1] for p in (np.array([MU]), crtbp_params(MU, harmonics_term(lunar_field(20))))]
    apart_km = np.linalg.norm(ends[0] - ends[1]) * LU_KM
    assert 1.0 < apart_km < 200.0


def test_the_filters_stm_with_the_field_matches_finite_differences():
    params = crtbp_params(MU, harmonics_term(lunar_field(30)))
    x0 = low_orbit_state(150.0, 60.0)
    dt = 600.0 / TU_S
    _, phi = rk4_state_stm(x0, dt, 64, params)
    numeric = np.empty((6, 6))
    for j in range(6):
        h = np.zeros(6)
        h[j] = 1e-7 if j < 3 else 1e-5 * np.sqrt(MU / (1837.4 / LU_KM))
        plus, minus = rk4_state_stm(x0 + h, dt, 64, params)[0], rk4_state_stm(x0 - h, dt, 64, params)[0]
        numeric[:, j] = (plus - minus) / (2 * h[j])
    assert np.abs(phi - numeric).max() < 1e-5 * np.abs(numeric).max()
    _, point_mass_phi = rk4_state_stm(x0, dt, 64, np.array([MU]))
    assert np.abs(phi - point_mass_phi).max() > 100 * np.abs(phi - numeric).max()  # the gradient is in it


def test_a_point_mass_parameter_vector_changes_nothing():
    x0 = low_orbit_state()
    assert np.array_equal(field_derivative(x0, np.array([MU])), derivative(x0, MU))
    acc, grad = np.empty(3), np.empty(6)
    params = crtbp_params(MU, harmonics_term(lunar_field(2)))
    moon_harmonics_into(params, int(params[3]), x0[0], x0[1], x0[2], True, acc, grad)
    assert np.all(np.isfinite(acc)) and abs(grad[0] + grad[1] + grad[2]) < 1e-10 * np.abs(grad).max()


def _scenario(**extra):
    mapping = {"name": "field", "duration_days": 1.0,
               "spacecraft": [{"name": "DRO", "orbit": "dro", "period_days": 14.0},
                              {"name": "LLO", "orbit": "lunar_keplerian",
                               "elements": {"a_km": 1837.4, "e": 0.0, "i_deg": 90, "raan_deg": 0, "argp_deg": 0,
                                            "ta_deg": 0}}],
               "links": [{"receiver": "DRO", "transponder": "LLO"}], "measurement": {"interval_s": 60},
               "noise": {"sigma_m": 5.0}, "monte_carlo": {"runs": 1, "seed": 1}, **extra}
    return validate_scenario(mapping, "field.yaml")


def test_the_integrators_scratch_is_written_before_it_is_read_and_is_large_enough():
    """The integrators pass one scratch to every evaluation (crtbp_field.field_scratch): filled with NaN at exactly
    terms_scratch_size, it gives the allocating call's acceleration and gradient bit for bit, for two harmonics
    terms of different degrees (the larger sets the size) and a J2, near the Moon and far from it (fewer degrees
    summed there). The size is the larger term's two tables to degree 30 + 2 (the gradient's recursion) and the
    nine of a term's acceleration and gradient."""
    params = crtbp_params(MU, harmonics_term(lunar_field(8)), j2_term(*lunar_j2()), harmonics_term(lunar_field(30)))
    size = terms_scratch_size(params)
    assert size == 9 + 2 * (packed_index(32, 32) + 1)
    for altitude_km in (50.0, 400.0, 60000.0):
        x, y, z = low_orbit_state(altitude_km, 70.0)[:3] + np.array([0.0, 300.0, -200.0]) / LU_KM
        for with_gradient in (False, True):
            expected_acc, expected_grad = np.zeros(3), np.zeros(6)
            added_terms_into(params, x, y, z, with_gradient, expected_acc, expected_grad)
            acc, grad = np.zeros(3), np.zeros(6)
            added_terms_scratch_into(params, x, y, z, with_gradient, acc, grad, np.full(size, np.nan))
            assert np.array_equal(acc, expected_acc) and np.array_equal(grad, expected_grad)
            assert np.all(np.isfinite(acc)) and np.any(acc != 0.0)


def test_the_scenario_keys_ask_for_the_field_and_refuse_what_cannot_be():
    from liaison_cli.scenario.truth import dynamics_model

    model = dynamics_model(_scenario(moon_gravity={"degree": 12, "filter_degree": 4}))
    assert field_degree(model.params) == 12 and field_degree(model.filter_params) == 4
    assert dynamics_model(_scenario(moon_gravity={"degree": 6})).filter_params is not None
    assert len(dynamics_model(_scenario(moon_gravity={"degree": 6, "filter_degree": 0})).filter_params) == 1
    with pytest.raises(Exception, match="at most moon_gravity.degree"):
        _scenario(moon_gravity={"degree": 4, "filter_degree": 8})
    from liaison_cli.dynamics.ephemeris_model import moon_field_of

    dated = dynamics_model(_scenario(moon_gravity={"degree": 4, "filter_field": "j2"}, dynamics="ephemeris",
                                     ephemeris={"epoch_utc": "2026-01-01T00:00:00"},
                                     measurement={"interval_s": 60, "light_time": False}))
    from liaison_cli.dynamics.ephemeris_dynamics import TERM_MOON_J2, term_of
    from liaison_cli.dynamics.ephemeris_model import terms_of
    from liaison_cli.dynamics.lunar_gravity import lunar_j2

    assert moon_field_of(dated.params)[0] == 4 and moon_field_of(dated.filter_params) is None
    assert np.array_equal(term_of(terms_of(dated.filter_params), TERM_MOON_J2), lunar_j2())  # J2 alone, closed form
