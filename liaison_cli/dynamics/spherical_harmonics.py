"""A body's gravity field in fully normalised spherical harmonics: the acceleration and its gradient (for the STM)
of the terms of degree 2 and above, in the body's own axes. Compiled; plain arrays in; `field_acceleration_into`
allocates nothing beyond two packed scratch tables per call (`acceleration_gradient_into`, for one-off calls,
builds the factors table too). Every square-root factor of the recursions depends on n and m alone, so a field
computes them once (`harmonic_factors`, carried in the propagators' parameter vectors) and an evaluation
(`field_acceleration_into`) only looks them up: at degree 20, half the cost of computing them in place, with the
same numbers bit for bit.

Method: Cunningham's solid harmonics V_nm, W_nm (Montenbruck & Gill, Satellite Orbits, 2000, Sec. 3.2.4:
Eq. 3.29-3.31 for the recursions, Eq. 3.33 for the acceleration), carried in normalised form
V̄_nm = N_nm V_nm with N_nm^2 = (2 - δ_m0)(2n + 1)(n - m)! / (n + m)!, so that the potential is
U = GM/R Σ (C̄_nm V̄_nm + S̄_nm W̄_nm) and every factor in the recursions and in the derivative rules is a square
root of a ratio of O(n) integers: nothing overflows or underflows at degree 200 above the reference sphere
((R / r)^(n + 1) is 1.4e-5 at degree 200 and 100 km altitude on the Moon). The recursion is in Cartesian
coordinates, so the poles are ordinary points (no 1 / cos(latitude)).

A derivative of a solid harmonic is a combination of solid harmonics one degree up (the rule behind M&G's
Eq. 3.33; `_solid_gradient` writes it in normalised form), so the acceleration takes the table to degree N + 1
and the gradient, the rule applied twice, to N + 2. Tests (tests/unit/dynamics/test_spherical_harmonics.py): the
acceleration against finite differences of the potential, the gradient against finite differences of the
acceleration, a zero trace (the potential is harmonic), the degree-2 field against its closed form, and the
potential against an independent sum of scipy's associated Legendre functions.

Far from the body the sum stops early (`effective_degree`): at the degree beyond which (R / r)^(n - 2), the
size of a degree-n term against degree 2's for coefficients of equal size, is below TRUNCATION_RATIO. The
coefficients fall with the degree (Kaula's rule), so what is left out is smaller still: against pyshtools at
degree 100 from 50 to 20,000 km the sum agrees to 3e-14 (tests). At the 9:2 NRHO's apolune (70,000 km from the
Moon) a degree-20 field stops at 11.

Coefficients are packed by `packed_index(n, m) = n (n + 1) / 2 + m`.
"""

import math

import numpy as np
from numba import njit

TRUNCATION_RATIO = 1e-14


@njit(cache=True, inline="always")
def packed_index(n, m):
    return n * (n + 1) // 2 + m


# Rows of harmonic_factors' table, each packed by packed_index(n, m): the column recursion's two factors (M&G Eq.
# 3.31, normalised) and the derivative rule's three (_solid_gradient).
COLUMN_A, COLUMN_B, SLOPE_C, SLOPE_A, SLOPE_B = 0, 1, 2, 3, 4


@njit(cache=True)
def harmonic_factors(top):
    """(5, packed_index(top, top) + 1): every square-root factor of the recursions to degree `top`, computed once per
    field instead of at every evaluation (they depend on n and m alone; the same expressions as the recursions had,
    so the numbers are bit for bit those of computing them in place). A field of degree N needs top = N + 2."""
    table = np.zeros((5, packed_index(top, top) + 1))
    for n in range(top + 1):
        for m in range(n + 1):
            k = packed_index(n, m)
            if n >= m + 2:
                table[COLUMN_A, k] = math.sqrt((2.0 * n - 1.0) * (2.0 * n + 1.0) / ((n - m) * (n + m)))
                table[COLUMN_B, k] = math.sqrt((2.0 * n + 1.0) * (n + m - 1.0) * (n - m - 1.0)
                                               / ((2.0 * n - 3.0) * (n + m) * (n - m)))
            q = (2.0 * n + 1.0) / (2.0 * n + 3.0)
            table[SLOPE_C, k] = math.sqrt(q * (n + m + 1.0) * (n - m + 1.0))
            if m == 0:
                table[SLOPE_A, k] = math.sqrt(0.5 * q * (n + 1.0) * (n + 2.0))
            else:  # (2 - δ_m0) / 2 = 1 for m > 0
                table[SLOPE_A, k] = math.sqrt(q * (n + m + 1.0) * (n + m + 2.0))
                table[SLOPE_B, k] = math.sqrt((2.0 if m == 1 else 1.0) * q * (n - m + 1.0) * (n - m + 2.0))
    return table


@njit(cache=True)
def solid_harmonics_into(x, y, z, radius, degree, factors, v, w):
    """v, w (packed to `degree`) <- the normalised V̄_nm, W̄_nm at (x, y, z) in the body's axes, lengths in the unit
    of `radius` (the field's reference radius); factors: harmonic_factors of at least `degree`."""
    r2 = x * x + y * y + z * z
    rho = radius / r2  # R / r^2
    xr, yr, zr, rr = x * rho, y * rho, z * rho, radius * rho  # x R / r^2, ..., R^2 / r^2
    v[0] = radius / math.sqrt(r2)
    w[0] = 0.0
    for m in range(degree + 1):
        mm = packed_index(m, m)
        if m > 0:  # the sectoral term from the one below it (M&G Eq. 3.30, normalised)
            f = math.sqrt(3.0) if m == 1 else math.sqrt((2.0 * m + 1.0) / (2.0 * m))
            below = packed_index(m - 1, m - 1)
            v[mm] = f * (xr * v[below] - yr * w[below])
            w[mm] = f * (xr * w[below] + yr * v[below])
        if m + 1 <= degree:  # one degree up (M&G Eq. 3.31 with n = m + 1: no n - 2 term)
            f = math.sqrt(2.0 * m + 3.0)
            up = packed_index(m + 1, m)
            v[up] = f * zr * v[mm]
            w[up] = f * zr * w[mm]
        for n in range(m + 2, degree + 1):  # the column recursion (M&G Eq. 3.31, normalised)
            k, k1, k2 = packed_index(n, m), packed_index(n - 1, m), packed_index(n - 2, m)
            a, b = factors[COLUMN_A, k], factors[COLUMN_B, k]
            v[k] = a * zr * v[k1] - b * rr * v[k2]
            w[k] = a * zr * w[k1] - b * rr * w[k2]


def solid_harmonics(x, y, z, radius, degree):
    """Normalised V̄_nm, W̄_nm (degree + 1, degree + 1) at (x, y, z) (solid_harmonics_into, unpacked; zero where
    m > n)."""
    size = packed_index(degree, degree) + 1
    v, w = np.empty(size), np.empty(size)
    solid_harmonics_into(float(x), float(y), float(z), float(radius), degree, harmonic_factors(degree), v, w)
    v2, w2 = np.zeros((degree + 1, degree + 1)), np.zeros((degree + 1, degree + 1))
    for n in range(degree + 1):
        for m in range(n + 1):
            v2[n, m], w2[n, m] = v[packed_index(n, m)], w[packed_index(n, m)]
    return v2, w2


@njit(cache=True, inline="always")
def _solid_gradient(v, w, factors, n, m, out):
    """out (6,) <- R times the gradients of V̄_nm and W̄_nm: [dV/dx, dV/dy, dV/dz, dW/dx, dW/dy, dW/dz], from the
    degree n + 1 row of the packed tables (the derivative of a solid harmonic, normalised; M&G Eq. 3.33's rule)."""
    k, up = packed_index(n, m), packed_index(n + 1, m)
    c = factors[SLOPE_C, k]
    out[2] = -c * v[up]
    out[5] = -c * w[up]
    if m == 0:
        a = factors[SLOPE_A, k]
        out[0] = -a * v[up + 1]
        out[1] = -a * w[up + 1]
        out[3] = 0.0
        out[4] = 0.0
        return
    a, b = factors[SLOPE_A, k], factors[SLOPE_B, k]
    vp, wp, vm, wm = v[up + 1], w[up + 1], v[up - 1], w[up - 1]
    out[0] = 0.5 * (-a * vp + b * vm)
    out[1] = 0.5 * (-a * wp - b * wm)
    out[3] = 0.5 * (-a * wp + b * wm)
    out[4] = 0.5 * (a * vp + b * vm)


@njit(cache=True, inline="always")
def effective_degree(degree, radius, r2):
    """The degree the sum needs at squared distance r2 (module docstring): degree itself inside 1.5 R."""
    ratio2 = radius * radius / r2
    if ratio2 >= 1.0 / 2.25:
        return degree
    needed = 2 + int(math.ceil(math.log(TRUNCATION_RATIO) / (0.5 * math.log(ratio2))))
    return min(degree, needed)


@njit(cache=True)
def potential(c, s, gm, radius, degree, position):
    """U of the terms of degree 2..degree at position (3,) in the body's axes (the central term excluded), in the
    units of gm and radius: GM/R Σ (C̄_nm V̄_nm + S̄_nm W̄_nm), c and s packed."""
    size = packed_index(degree, degree) + 1
    v, w = np.empty(size), np.empty(size)
    solid_harmonics_into(position[0], position[1], position[2], radius, degree, harmonic_factors(degree), v, w)
    total = 0.0
    for n in range(2, degree + 1):
        for m in range(n + 1):
            k = packed_index(n, m)
            total += c[k] * v[k] + s[k] * w[k]
    return gm / radius * total


@njit(cache=True)
def acceleration_gradient_into(c, s, gm, radius, degree, x, y, z, with_gradient, acc, grad):
    """field_acceleration_into with the factors computed for this call (tests and one-off evaluations; the
    propagators carry the factors in their parameter vectors)."""
    field_acceleration_into(c, s, harmonic_factors(degree + 2), gm, radius, degree, x, y, z, with_gradient, acc, grad)


@njit(cache=True)
def field_acceleration_into(c, s, factors, gm, radius, degree, x, y, z, with_gradient, acc, grad):
    """acc (3,) <- the acceleration of the terms of degree 2..degree at (x, y, z) in the body's axes; with
    with_gradient, grad (6,) <- its gradient (gxx, gyy, gzz, gxy, gxz, gyz); c and s packed (module docstring),
    factors: harmonic_factors(degree + 2). Units: those of gm and radius (lengths of x, y, z in radius's unit)."""
    degree = effective_degree(degree, radius, x * x + y * y + z * z)
    top = degree + 2 if with_gradient else degree + 1
    v, w = np.empty(packed_index(top, top) + 1), np.empty(packed_index(top, top) + 1)
    solid_harmonics_into(x, y, z, radius, top, factors, v, w)
    first = np.empty(6)
    second = np.empty(6)
    ax = ay = az = 0.0
    gxx = gyy = gzz = gxy = gxz = gyz = 0.0
    for n in range(2, degree + 1):
        for m in range(n + 1):
            k = packed_index(n, m)
            cnm, snm = c[k], s[k]
            if cnm == 0.0 and snm == 0.0:
                continue
            _solid_gradient(v, w, factors, n, m, first)
            ax += cnm * first[0] + snm * first[3]
            ay += cnm * first[1] + snm * first[4]
            az += cnm * first[2] + snm * first[5]
            if not with_gradient:
                continue
            # d/dz of the gradient: -c times the gradient of the (n + 1, m) harmonics
            cz = factors[SLOPE_C, k]
            _solid_gradient(v, w, factors, n + 1, m, second)
            gzz += -cz * (cnm * second[2] + snm * second[5])
            gxz += -cz * (cnm * second[0] + snm * second[3])
            gyz += -cz * (cnm * second[1] + snm * second[4])
            # d/dx and d/dy of the gradient: combinations of the (n + 1, m +- 1) harmonics' gradients
            if m == 0:
                a0 = factors[SLOPE_A, k]
                _solid_gradient(v, w, factors, n + 1, 1, second)
                # dV̄_n0/dx = -a0 V̄_{n+1,1}, dV̄_n0/dy = -a0 W̄_{n+1,1}
                gxx += -a0 * cnm * second[0]
                gxy += -a0 * cnm * second[1]
                gyy += -a0 * cnm * second[4]
                continue
            a, b = factors[SLOPE_A, k], factors[SLOPE_B, k]
            _solid_gradient(v, w, factors, n + 1, m + 1, second)  # gradients of V̄, W̄ at (n + 1, m + 1)
            gvp_x, gvp_y, gwp_x, gwp_y = second[0], second[1], second[3], second[4]
            _solid_gradient(v, w, factors, n + 1, m - 1, second)  # ... and at (n + 1, m - 1)
            gvm_x, gvm_y, gwm_x, gwm_y = second[0], second[1], second[3], second[4]
            # dV̄/dx = (-a V̄p + b V̄m) / 2, dW̄/dx = (-a W̄p + b W̄m) / 2,
            # dV̄/dy = (-a W̄p - b W̄m) / 2, dW̄/dy = (a V̄p + b V̄m) / 2
            gxx += 0.5 * (cnm * (-a * gvp_x + b * gvm_x) + snm * (-a * gwp_x + b * gwm_x))
            gxy += 0.5 * (cnm * (-a * gvp_y + b * gvm_y) + snm * (-a * gwp_y + b * gwm_y))
            gyy += 0.5 * (cnm * (-a * gwp_y - b * gwm_y) + snm * (a * gvp_y + b * gvm_y))
    scale = gm / (radius * radius)
    acc[0], acc[1], acc[2] = scale * ax, scale * ay, scale * az
    if with_gradient:
        scale2 = scale / radius
        grad[0], grad[1], grad[2] = scale2 * gxx, scale2 * gyy, scale2 * gzz
        grad[3], grad[4], grad[5] = scale2 * gxy, scale2 * gxz, scale2 * gyz
