"""A body's gravity field in fully normalised spherical harmonics: the acceleration and its gradient (for the STM)
of the terms of degree 2 and above, in the body's own axes. Compiled; plain arrays in; `field_acceleration_into`
allocates nothing beyond two packed scratch tables per call, and `field_acceleration_scratch_into` takes the
caller's (the CRTBP's integrators allocate them once per call, not per evaluation).

What depends on the field alone is computed once per field and carried in the propagators' parameter vectors
(`field_payload`, read back by `payload_tables`): every square-root factor of the recursions (`harmonic_factors`:
they depend on n and m alone) and the field itself as weights on the solid harmonics (`field_weights`). The
acceleration and its gradient are linear in the solid harmonics one and two degrees up (below), so an evaluation
is the recursion followed by one weighted sum per output (3 for the acceleration, 6 for the gradient), with no
per-term derivative rules left in it. Against applying the rules term by term, in one session
(`python -m benchmarks.lunar_field`, 100 km above the reference sphere): the acceleration 1.7-1.9 times and the
acceleration with its gradient 2.5-3 times faster at degrees 20-200 (docs/performance.md), the same field to
rounding (a summation order changed: the tests' tolerances are unchanged). `acceleration_gradient_into` builds the
tables for one call (tests, one-off evaluations).

Method: Cunningham's solid harmonics V_nm, W_nm (Montenbruck & Gill, Satellite Orbits, 2000, Sec. 3.2.4:
Eq. 3.29-3.31 for the recursions, Eq. 3.33 for the acceleration), carried in normalised form
V̄_nm = N_nm V_nm with N_nm^2 = (2 - δ_m0)(2n + 1)(n - m)! / (n + m)!, so that the potential is
U = GM/R Σ (C̄_nm V̄_nm + S̄_nm W̄_nm) and every factor in the recursions and in the derivative rules is a square
root of a ratio of O(n) integers: nothing overflows or underflows at degree 200 above the reference sphere
((R / r)^(n + 1) is 1.4e-5 at degree 200 and 100 km altitude on the Moon). The recursion is in Cartesian
coordinates, so the poles are ordinary points (no 1 / cos(latitude)).

A derivative of a solid harmonic is a combination of solid harmonics one degree up (the rule behind M&G's
Eq. 3.33; `_add_derivative` writes it in normalised form), so the acceleration takes the table to degree N + 1
and the gradient, the rule applied twice, to N + 2: a degree-n term's acceleration lies in row n + 1 of the weight
tables and its gradient in row n + 2, so a sum stopped early (below) reads fewer rows. Tests (tests/unit/dynamics/test_spherical_harmonics.py): the
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
# 3.31, normalised), the derivative rule's three (the weight tables'), and the factors of the two terms each row
# starts from, at (n, n) (M&G Eq. 3.30) and at (n, n - 1) (Eq. 3.31 with no n - 2 term).
COLUMN_A, COLUMN_B, SLOPE_C, SLOPE_A, SLOPE_B, SECTORAL, SUBDIAGONAL = 0, 1, 2, 3, 4, 5, 6
FACTOR_ROWS = 7
# Columns of the weight tables (field_weights): V̄'s and W̄'s weight in each output.
ACC_COLUMNS = 6  # ax, ay, az
GRAD_COLUMNS = 12  # gxx, gyy, gzz, gxy, gxz, gyz


@njit(cache=True)
def harmonic_factors(top):
    """(FACTOR_ROWS, packed_index(top, top) + 1): every square-root factor of the recursions to degree `top`, computed
    once per field instead of at every evaluation (they depend on n and m alone; the same expressions as the
    recursions had in place). A field of degree N needs top = N + 2."""
    table = np.zeros((FACTOR_ROWS, packed_index(top, top) + 1))
    for n in range(top + 1):
        if n >= 1:
            table[SECTORAL, packed_index(n, n)] = math.sqrt(3.0) if n == 1 else math.sqrt((2.0 * n + 1.0) / (2.0 * n))
            table[SUBDIAGONAL, packed_index(n, n - 1)] = math.sqrt(2.0 * (n - 1) + 3.0)
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
    of `radius` (the field's reference radius); factors: harmonic_factors of at least `degree`. Row by row (packed
    storage keeps a degree's orders together): each order of row n from rows n - 1 and n - 2 (M&G Eq. 3.31),
    independent of one another, then (n, n - 1) and (n, n) from (n - 1, n - 1) (Eq. 3.31 and 3.30)."""
    r2 = x * x + y * y + z * z
    rho = radius / r2  # R / r^2
    xr, yr, zr, rr = x * rho, y * rho, z * rho, radius * rho  # x R / r^2, ..., R^2 / r^2
    v[0] = radius / math.sqrt(r2)
    w[0] = 0.0
    column_a, column_b = factors[COLUMN_A], factors[COLUMN_B]
    for n in range(1, degree + 1):
        row, below_row = packed_index(n, 0), packed_index(n - 1, 0)
        # Unsigned indices in the column loop: numba checks every signed index for wraparound (a negative one counts
        # from the end), which kept LLVM from vectorising the loop; unsigned, the recursion runs 2-3 times
        # faster, bit for bit (its arithmetic is unchanged).
        urow, ubelow, utwo_below = np.uint64(row), np.uint64(below_row), np.uint64(packed_index(n - 2, 0))
        for m in range(np.uint64(n - 1)):  # the column recursion (M&G Eq. 3.31, normalised)
            k, k1, k2 = urow + m, ubelow + m, utwo_below + m
            a, b = column_a[k], column_b[k]
            v[k] = a * zr * v[k1] - b * rr * v[k2]
            w[k] = a * zr * w[k1] - b * rr * w[k2]
        corner = below_row + n - 1  # (n - 1, n - 1)
        vc, wc = v[corner], w[corner]
        f = factors[SUBDIAGONAL, row + n - 1]  # one degree up (M&G Eq. 3.31 with no n - 2 term)
        v[row + n - 1] = f * zr * vc
        w[row + n - 1] = f * zr * wc
        f = factors[SECTORAL, row + n]  # the sectoral term from the one below it (M&G Eq. 3.30, normalised)
        v[row + n] = f * (xr * vc - yr * wc)
        w[row + n] = f * (xr * wc + yr * vc)


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
def _add_derivative(weights, output, factors, n, m, component, weight):
    """weights[:, 2 output] (V̄'s) and weights[:, 2 output + 1] (W̄'s) += weight times R times one derivative of the
    (n, m) harmonics, a combination of the degree n + 1 row (the derivative of a solid harmonic, normalised: M&G Eq.
    3.33's rule). component: 0-2 dV̄/dx, dy, dz; 3-5 dW̄/dx, dy, dz."""
    k, up = packed_index(n, m), packed_index(n + 1, m)
    v_col, w_col = 2 * output, 2 * output + 1
    if component == 2 or component == 5:
        weights[up, v_col if component == 2 else w_col] -= weight * factors[SLOPE_C, k]
        return
    a = factors[SLOPE_A, k]
    if m == 0:  # dV̄_n0/dx = -a V̄_{n+1,1}, dV̄_n0/dy = -a W̄_{n+1,1}; W̄_n0 = 0
        if component == 0:
            weights[up + 1, v_col] -= weight * a
        elif component == 1:
            weights[up + 1, w_col] -= weight * a
        return
    half_a, half_b = 0.5 * a, 0.5 * factors[SLOPE_B, k]
    if component == 0:  # dV̄/dx = (-a V̄p + b V̄m) / 2
        weights[up + 1, v_col] -= weight * half_a
        weights[up - 1, v_col] += weight * half_b
    elif component == 1:  # dV̄/dy = (-a W̄p - b W̄m) / 2
        weights[up + 1, w_col] -= weight * half_a
        weights[up - 1, w_col] -= weight * half_b
    elif component == 3:  # dW̄/dx = (-a W̄p + b W̄m) / 2
        weights[up + 1, w_col] -= weight * half_a
        weights[up - 1, w_col] += weight * half_b
    else:  # dW̄/dy = (a V̄p + b V̄m) / 2
        weights[up + 1, v_col] += weight * half_a
        weights[up - 1, v_col] += weight * half_b


@njit(cache=True)
def field_weights(c, s, degree, factors):
    """The field as weights on the solid harmonics (field_acceleration_into): acc_weights (packed_index(degree + 1,
    degree + 1) + 1, ACC_COLUMNS) and grad_weights (packed_index(degree + 2, degree + 2) + 1, GRAD_COLUMNS), such that
    R^2/GM times the acceleration's x component is Σ_k acc_weights[k, 0] V̄_k + acc_weights[k, 1] W̄_k, and so on for
    y, z and the gradient's six (times R^3/GM). The acceleration of degree n's terms is the derivative rule applied
    once (row n + 1), its gradient twice (row n + 2), so a sum stopped at degree d (effective_degree) reads rows up
    to d + 1 and d + 2. c, s packed to `degree`; factors: harmonic_factors(degree + 2)."""
    acc_weights = np.zeros((packed_index(degree + 1, degree + 1) + 1, ACC_COLUMNS))
    grad_weights = np.zeros((packed_index(degree + 2, degree + 2) + 1, GRAD_COLUMNS))
    for n in range(2, degree + 1):
        for m in range(n + 1):
            k = packed_index(n, m)
            cnm, snm = c[k], s[k]
            if cnm == 0.0 and snm == 0.0:
                continue
            for axis in range(3):  # a_axis = Σ C̄ dV̄/d axis + S̄ dW̄/d axis
                _add_derivative(acc_weights, axis, factors, n, m, axis, cnm)
                _add_derivative(acc_weights, axis, factors, n, m, 3 + axis, snm)
            # d/dz of the gradient's x, y, z: -c_nm times the derivatives of the (n + 1, m) harmonics (gxz, gyz, gzz)
            cz = factors[SLOPE_C, k]
            for output, component in ((4, 0), (5, 1), (2, 2)):
                _add_derivative(grad_weights, output, factors, n + 1, m, component, -cz * cnm)
                _add_derivative(grad_weights, output, factors, n + 1, m, 3 + component, -cz * snm)
            # d/dx and d/dy: combinations of the (n + 1, m +- 1) harmonics' derivatives (gxx, gxy, gyy)
            a = factors[SLOPE_A, k]
            if m == 0:  # dV̄_n0/dx = -a V̄_{n+1,1}, dV̄_n0/dy = -a W̄_{n+1,1}
                for output, component in ((0, 0), (3, 1), (1, 4)):  # a loop: literal indices compile a callee again
                    _add_derivative(grad_weights, output, factors, n + 1, m + 1, component, -a * cnm)
                continue
            half_a, half_b = 0.5 * a, 0.5 * factors[SLOPE_B, k]
            # d/dx: dV̄/dx = (-a V̄p + b V̄m) / 2, dW̄/dx = (-a W̄p + b W̄m) / 2 (p, m: orders m + 1, m - 1)
            for output, v_part, w_part in ((0, 0, 3), (3, 1, 4)):  # gxx: their x derivatives; gxy: their y ones
                _add_derivative(grad_weights, output, factors, n + 1, m + 1, v_part, -half_a * cnm)
                _add_derivative(grad_weights, output, factors, n + 1, m - 1, v_part, half_b * cnm)
                _add_derivative(grad_weights, output, factors, n + 1, m + 1, w_part, -half_a * snm)
                _add_derivative(grad_weights, output, factors, n + 1, m - 1, w_part, half_b * snm)
            # gyy: dV̄/dy = (-a W̄p - b W̄m) / 2, dW̄/dy = (a V̄p + b V̄m) / 2, their y derivatives
            for output, order, component, weight in ((1, m + 1, 4, -half_a * cnm), (1, m - 1, 4, -half_b * cnm),
                                                     (1, m + 1, 1, half_a * snm), (1, m - 1, 1, half_b * snm)):
                _add_derivative(grad_weights, output, factors, n + 1, order, component, weight)
    return acc_weights, grad_weights


def field_payload(c, s, degree: int, radius: float) -> np.ndarray:
    """A field as one flat vector for the propagators' parameter vectors: degree, reference radius, then the
    recursions' factors (harmonic_factors(degree + 2)), acc_weights and grad_weights (field_weights), row-major.
    Read back by payload_tables."""
    factors = harmonic_factors(degree + 2)
    acc_weights, grad_weights = field_weights(np.asarray(c, dtype=float), np.asarray(s, dtype=float), degree,
                                              factors)
    return np.concatenate([[float(degree), float(radius)], factors.ravel(), acc_weights.ravel(),
                           grad_weights.ravel()])


@njit(cache=True, inline="always")
def payload_tables(payload):
    """(degree, radius, (factors, acc_weights, grad_weights)) of a field_payload; views, no copy."""
    degree = int(payload[0])
    rows = packed_index(degree + 2, degree + 2) + 1
    acc_rows = packed_index(degree + 1, degree + 1) + 1
    start = 2 + FACTOR_ROWS * rows
    factors = payload[2:start].reshape((FACTOR_ROWS, rows))
    acc_weights = payload[start:start + ACC_COLUMNS * acc_rows].reshape((acc_rows, ACC_COLUMNS))
    start += ACC_COLUMNS * acc_rows
    grad_weights = payload[start:start + GRAD_COLUMNS * rows].reshape((rows, GRAD_COLUMNS))
    return degree, payload[1], (factors, acc_weights, grad_weights)


@njit(cache=True)
def acceleration_gradient_into(c, s, gm, radius, degree, x, y, z, with_gradient, acc, grad):
    """field_acceleration_into with the field's tables built for this call (tests and one-off evaluations; the
    propagators carry them in their parameter vectors: field_payload)."""
    factors = harmonic_factors(degree + 2)
    acc_weights, grad_weights = field_weights(c, s, degree, factors)
    field_acceleration_into((factors, acc_weights, grad_weights), gm, radius, degree, x, y, z, with_gradient, acc,
                            grad)


@njit(cache=True, inline="always")
def harmonics_scratch_size(degree):
    """The length of each of the two scratch tables (V̄, W̄) field_acceleration_scratch_into needs at `degree`."""
    return packed_index(degree + 2, degree + 2) + 1


@njit(cache=True, inline="always")
def point_scratch_size(degree, radius, x, y, z):
    """harmonics_scratch_size for the degree the point (x, y, z) needs (effective_degree): far from the body a few
    hundred entries where the field's whole degree (200) would take 20,000."""
    return harmonics_scratch_size(effective_degree(degree, radius, x * x + y * y + z * z))


@njit(cache=True)
def field_acceleration_into(tables, gm, radius, degree, x, y, z, with_gradient, acc, grad):
    """acc (3,) <- the acceleration of the terms of degree 2..degree at (x, y, z) in the body's axes; with
    with_gradient, grad (6,) <- its gradient (gxx, gyy, gzz, gxy, gxz, gyz). tables: (factors, acc_weights,
    grad_weights) of the field (field_weights; payload_tables). Units: those of gm and radius (lengths of x, y, z in
    radius's unit). Allocates its two scratch tables, as long as the point needs (point_scratch_size); the CRTBP's
    integrators pass theirs (field_acceleration_scratch_into)."""
    size = point_scratch_size(degree, radius, x, y, z)
    field_acceleration_scratch_into(tables, gm, radius, degree, x, y, z, with_gradient, acc, grad, np.empty(size),
                                    np.empty(size))


@njit(cache=True)
def field_acceleration_scratch_into(tables, gm, radius, degree, x, y, z, with_gradient, acc, grad, v, w):
    """field_acceleration_into with the caller's scratch tables v, w (each at least harmonics_scratch_size(degree)
    long, overwritten). The solid harmonics to the degree the point needs (effective_degree) plus one (two with the
    gradient), then one weighted sum per output."""
    factors, acc_weights, grad_weights = tables
    degree = effective_degree(degree, radius, x * x + y * y + z * z)
    top = degree + 2 if with_gradient else degree + 1
    solid_harmonics_into(x, y, z, radius, top, factors, v, w)
    ax = ay = az = 0.0
    # unsigned indices, as in solid_harmonics_into's column loop (the sums' order is unchanged)
    # degree 2's terms start at row 3
    for k in range(np.uint64(packed_index(3, 0)), np.uint64(packed_index(degree + 1, degree + 1) + 1)):
        vk, wk = v[k], w[k]
        ax += acc_weights[k, 0] * vk + acc_weights[k, 1] * wk
        ay += acc_weights[k, 2] * vk + acc_weights[k, 3] * wk
        az += acc_weights[k, 4] * vk + acc_weights[k, 5] * wk
    scale = gm / (radius * radius)
    acc[0], acc[1], acc[2] = scale * ax, scale * ay, scale * az
    if not with_gradient:
        return
    gxx = gyy = gzz = gxy = gxz = gyz = 0.0
    for k in range(np.uint64(packed_index(4, 0)), np.uint64(packed_index(degree + 2, degree + 2) + 1)):  # gradient: 4
        vk, wk = v[k], w[k]
        gxx += grad_weights[k, 0] * vk + grad_weights[k, 1] * wk
        gyy += grad_weights[k, 2] * vk + grad_weights[k, 3] * wk
        gzz += grad_weights[k, 4] * vk + grad_weights[k, 5] * wk
        gxy += grad_weights[k, 6] * vk + grad_weights[k, 7] * wk
        gxz += grad_weights[k, 8] * vk + grad_weights[k, 9] * wk
        gyz += grad_weights[k, 10] * vk + grad_weights[k, 11] * wk
    scale2 = scale / radius
    grad[0], grad[1], grad[2] = scale2 * gxx, scale2 * gyy, scale2 * gzz
    grad[3], grad[4], grad[5] = scale2 * gxy, scale2 * gxz, scale2 * gyz
