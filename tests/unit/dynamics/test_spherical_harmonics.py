"""The normalised spherical-harmonic field (dynamics.spherical_harmonics) against physics and an independent sum:
the acceleration is the potential's gradient and the gradient the acceleration's (finite differences), the
gradient has zero trace (the potential is harmonic), degree 2 matches its closed form, and the potential matches
a sum of scipy's orthonormal spherical harmonics, to degree 200, at the pole too."""

import math

import numpy as np
import pytest
from scipy.special import sph_harm_y

from liaison_cli.dynamics.spherical_harmonics import (acceleration_gradient_into, field_acceleration_into, field_payload,
                                                       packed_index, payload_tables, potential)

GM, RADIUS = 4902.8, 1738.0  # km^3/s^2, km: the Moon's size, so the numbers are the ones the field meets


def kaula_coefficients(degree, seed=3, scale=3.6e-4):
    """Random packed C̄, S̄ with a Kaula-like power (scale / n^2), S̄_n0 = 0."""
    rng = np.random.default_rng(seed)
    size = packed_index(degree, degree) + 1
    c, s = np.zeros(size), np.zeros(size)
    for n in range(2, degree + 1):
        for m in range(n + 1):
            k = packed_index(n, m)
            c[k] = rng.normal() * scale / n**2
            s[k] = 0.0 if m == 0 else rng.normal() * scale / n**2
    return c, s


def field(c, s, degree, position, with_gradient=True):
    acc, grad = np.empty(3), np.empty(6)
    acceleration_gradient_into(c, s, GM, RADIUS, degree, position[0], position[1], position[2], with_gradient, acc,
                               grad)
    return acc, grad


def gradient_matrix(g):
    gxx, gyy, gzz, gxy, gxz, gyz = g
    return np.array([[gxx, gxy, gxz], [gxy, gyy, gyz], [gxz, gyz, gzz]])


def independent_potential(c, s, degree, position):
    """GM/r Σ (R/r)^n P̄_nm(sin φ) (C̄ cos mλ + S̄ sin mλ) from scipy's orthonormal Y_nm (Condon-Shortley phase):
    P̄_nm e^{imλ} = (-1)^m sqrt(4π (2 - δ_m0)) Y_nm(colatitude, λ)."""
    x, y, z = position
    r = math.sqrt(x * x + y * y + z * z)
    colatitude, longitude = math.acos(z / r), math.atan2(y, x)
    total = 0.0
    for n in range(2, degree + 1):
        for m in range(n + 1):
            k = packed_index(n, m)
            ynm = sph_harm_y(n, m, colatitude, longitude)
            factor = (-1) ** m * math.sqrt(4 * math.pi * (1.0 if m == 0 else 2.0))
            total += (RADIUS / r) ** n * factor * (c[k] * ynm.real + s[k] * ynm.imag)
    return GM / r * total


POINTS = [np.array([1838.0, 0.0, 0.0]), np.array([1200.0, -900.0, 1100.0]), np.array([0.0, 0.0, 1838.0]),
          np.array([1e-3, -2e-3, -1900.0]), np.array([-3000.0, 2500.0, -400.0])]


@pytest.mark.parametrize("degree", [2, 8, 50])
@pytest.mark.parametrize("point", range(len(POINTS)))
def test_acceleration_is_the_potentials_gradient(degree, point):
    c, s = kaula_coefficients(degree)
    position = POINTS[point]
    acc, _ = field(c, s, degree, position)
    h = 1e-3  # km: central differences, error ~ h^2 |d3U|
    numeric = np.array([(potential(c, s, GM, RADIUS, degree, position + h * e)
                         - potential(c, s, GM, RADIUS, degree, position - h * e)) / (2 * h) for e in np.eye(3)])
    assert np.allclose(acc, numeric, rtol=1e-6, atol=1e-9 * np.abs(acc).max())


@pytest.mark.parametrize("degree", [2, 8, 50])
@pytest.mark.parametrize("point", range(len(POINTS)))
def test_gradient_is_the_accelerations_and_traceless(degree, point):
    c, s = kaula_coefficients(degree)
    position = POINTS[point]
    _, grad = field(c, s, degree, position)
    g = gradient_matrix(grad)
    h = 1e-2
    numeric = np.column_stack([(field(c, s, degree, position + h * e, False)[0]
                                - field(c, s, degree, position - h * e, False)[0]) / (2 * h) for e in np.eye(3)])
    assert np.allclose(g, numeric, rtol=1e-5, atol=1e-7 * np.abs(g).max())
    assert abs(np.trace(g)) < 1e-12 * np.abs(g).max()  # Laplace: the potential is harmonic outside the body


def test_degree_two_matches_its_closed_form():
    """C̄20 (J2 = -√5 C̄20) and C̄22 against the textbook expressions of their accelerations."""
    c, s = np.zeros(6), np.zeros(6)
    c[packed_index(2, 0)], c[packed_index(2, 2)] = -9.0884e-5, 3.4673e-5
    x, y, z = 1500.0, -700.0, 900.0
    r = math.sqrt(x * x + y * y + z * z)
    j2 = -math.sqrt(5.0) * c[packed_index(2, 0)]
    k = 1.5 * j2 * GM * RADIUS**2 / r**5
    w = 5 * z * z / r**2
    zonal = np.array([-k * x * (1 - w), -k * y * (1 - w), -k * z * (3 - w)])
    # C22 unnormalised = C̄22 sqrt(5 / 12); U22 = 3 GM R^2 C22 (x^2 - y^2) / r^5
    c22 = c[packed_index(2, 2)] * math.sqrt(5.0 / 12.0)
    q = 3 * GM * RADIUS**2 * c22
    u = x * x - y * y
    sectoral = q * np.array([2 * x / r**5 - 5 * u * x / r**7, -2 * y / r**5 - 5 * u * y / r**7, -5 * u * z / r**7])
    acc, _ = field(c, s, 2, np.array([x, y, z]))
    assert np.allclose(acc, zonal + sectoral, rtol=1e-12)


@pytest.mark.parametrize("degree, point", [(20, 1), (20, 2), (200, 0), (200, 3), (200, 4)])
def test_potential_matches_an_independent_sum_to_degree_200(degree, point):
    c, s = kaula_coefficients(degree, seed=7)
    position = POINTS[point]
    ours = potential(c, s, GM, RADIUS, degree, position)
    theirs = independent_potential(c, s, degree, position)
    # against the central term GM / r: the sum's terms cancel near the pole, so its own size is no yardstick
    assert abs(ours - theirs) <= 1e-12 * GM / np.linalg.norm(position)


def test_degree_200_at_100_km_is_finite_and_harmonic():
    c, s = kaula_coefficients(200, seed=11)
    acc, grad = field(c, s, 200, np.array([900.0, 1000.0, -1100.0]) * 1838.0 / math.sqrt(900**2 + 1000**2 + 1100**2))
    g = gradient_matrix(grad)
    assert np.all(np.isfinite(acc)) and np.all(np.isfinite(g))
    assert abs(np.trace(g)) < 1e-10 * np.abs(g).max()


def test_acceleration_matches_pyshtools_at_1000_points_to_degree_100():
    """Issue 46's acceptance: GRGM1200A to degree 100 against pyshtools' point evaluation (MakeGravGridPoint, the
    same coefficients, the central term left out) at 1,000 random points from 50 to 20,000 km altitude."""
    import pyshtools

    from liaison_cli.dynamics.lunar_gravity import lunar_field

    degree = 100
    moon = lunar_field(degree)
    cilm = np.zeros((2, degree + 1, degree + 1))
    for n in range(2, degree + 1):
        for m in range(n + 1):
            cilm[0, n, m], cilm[1, n, m] = moon.c[packed_index(n, m)], moon.s[packed_index(n, m)]
    rng = np.random.default_rng(46)
    count = 1000
    altitude_km = 50.0 + (20000.0 - 50.0) * rng.random(count) ** 3  # most of them low, where the field is rough
    latitude, longitude = np.degrees(np.arcsin(rng.uniform(-1, 1, count))), rng.uniform(0.0, 360.0, count)
    acc, grad = np.empty(3), np.empty(6)
    _, _, tables = payload_tables(field_payload(moon.c, moon.s, degree, moon.radius_km))
    worst = 0.0
    for h, lat, lon in zip(altitude_km, latitude, longitude):
        r_km = 1737.4 + h
        g_r, g_theta, g_phi = pyshtools.gravmag.MakeGravGridPoint(cilm, moon.gm_km3_s2 * 1e9, moon.radius_km * 1e3,
                                                                  r_km * 1e3, lat, lon)
        theta, phi = np.radians(90.0 - lat), np.radians(lon)
        radial = np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])
        south = np.array([np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi), -np.sin(theta)])
        east = np.array([-np.sin(phi), np.cos(phi), 0.0])
        theirs = g_r * radial + g_theta * south + g_phi * east
        p = r_km * radial
        field_acceleration_into(tables, moon.gm_km3_s2, moon.radius_km, degree, p[0], p[1], p[2], False, acc, grad)
        worst = max(worst, np.linalg.norm(acc * 1e3 - theirs) / np.linalg.norm(theirs))
    assert worst <= 1e-12


def test_the_factors_table_holds_the_recursions_factors_exactly():
    """harmonic_factors (computed once per field) holds, bit for bit, the factors the recursions computed in place
    before (the expressions of M&G Eq. 3.31 and 3.33, normalised, evaluated here in Python)."""
    import math

    from liaison_cli.dynamics.spherical_harmonics import (COLUMN_A, COLUMN_B, SECTORAL, SLOPE_A, SLOPE_B, SLOPE_C,
                                                           SUBDIAGONAL, harmonic_factors)

    top = 40
    table = harmonic_factors(top)
    for n in range(1, top + 1):  # the two terms each row starts from (M&G Eq. 3.30 and 3.31 with no n - 2 term)
        sectoral = math.sqrt(3.0) if n == 1 else math.sqrt((2.0 * n + 1.0) / (2.0 * n))
        assert table[SECTORAL, packed_index(n, n)] == sectoral
        assert table[SUBDIAGONAL, packed_index(n, n - 1)] == math.sqrt(2.0 * (n - 1) + 3.0)
    for n in range(top + 1):
        for m in range(n + 1):
            k = packed_index(n, m)
            q = (2.0 * n + 1.0) / (2.0 * n + 3.0)
            assert table[SLOPE_C, k] == math.sqrt(q * (n + m + 1.0) * (n - m + 1.0))
            if m == 0:
                assert table[SLOPE_A, k] == math.sqrt(0.5 * q * (n + 1.0) * (n + 2.0))
            else:
                assert table[SLOPE_A, k] == math.sqrt(q * (n + m + 1.0) * (n + m + 2.0))
                assert table[SLOPE_B, k] == math.sqrt((2.0 if m == 1 else 1.0) * q * (n - m + 1.0) * (n - m + 2.0))
            if n >= m + 2:
                assert table[COLUMN_A, k] == math.sqrt((2.0 * n - 1.0) * (2.0 * n + 1.0) / ((n - m) * (n + m)))
                assert table[COLUMN_B, k] == math.sqrt((2.0 * n + 1.0) * (n + m - 1.0) * (n - m - 1.0)
                                                       / ((2.0 * n - 3.0) * (n + m) * (n - m)))
