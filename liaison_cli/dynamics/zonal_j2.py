"""A body's J2 (its oblateness) alone, in closed form: the acceleration and its gradient, for a field term that a
flight filter often carries instead of a full spherical-harmonic field (dynamics.crtbp_field's TERM_J2).

With the potential's sign convention a = grad V, the J2 term of V is
    V_J2 = -(GM J2 R^2 / 2) (3 z^2 - r^2) / r^5
(the degree-2 zonal term of the geopotential; e.g. Vallado, Fundamentals of Astrodynamics and Applications,
ch. 8), so
    a_i = k x_i / r^5 (5 s - c_i),  k = 3 GM J2 R^2 / 2,  s = z^2 / r^2,  c = (1, 1, 3),
and its gradient, written out here and checked against central differences and against the Cunningham evaluator
fed C20 alone (tests/unit/dynamics/test_zonal_j2.py):
    G_ij = k / r^5 [delta_ij (5 s - c_i) + x_i x_j / r^2 (5 c_i - 35 s) + 10 x_i z delta_jz / r^2].
Its trace is zero (Laplace). Body-fixed axes with z along the body's spin axis; units are the caller's.
"""

import numpy as np
from numba import njit


@njit(cache=True)
def j2_acceleration_gradient_into(gm, j2, radius, x, y, z, with_gradient, acc, grad):
    """acc (3,) <- the J2 acceleration at the body-fixed position (x, y, z); with with_gradient, grad (6,) <- its
    gradient (gxx, gyy, gzz, gxy, gxz, gyz). gm, radius and the position in consistent units."""
    r2 = x * x + y * y + z * z
    r = np.sqrt(r2)
    k = 1.5 * gm * j2 * radius * radius
    s = z * z / r2
    k5 = k / (r2 * r2 * r)
    acc[0] = k5 * x * (5.0 * s - 1.0)
    acc[1] = k5 * y * (5.0 * s - 1.0)
    acc[2] = k5 * z * (5.0 * s - 3.0)
    if not with_gradient:
        return
    k7 = k5 / r2
    lateral = 5.0 - 35.0 * s  # 5 c_i - 35 s for the x and y rows
    grad[0] = k5 * (5.0 * s - 1.0) + k7 * x * x * lateral
    grad[1] = k5 * (5.0 * s - 1.0) + k7 * y * y * lateral
    grad[2] = k5 * (30.0 * s - 35.0 * s * s - 3.0)
    grad[3] = k7 * x * y * lateral
    grad[4] = k7 * x * z * (15.0 - 35.0 * s)
    grad[5] = k7 * y * z * (15.0 - 35.0 * s)
