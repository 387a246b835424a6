"""The range model: partials against central differences and the light-time correction."""

import numpy as np

from liaison_cli.dynamics.constants import LU_KM, MU, SPEED_OF_LIGHT_LU_TU, TU_S
from liaison_cli.dynamics.integrators.dop853 import dop853_states
from liaison_cli.dynamics.trajectory import CrtbpTrajectory
from liaison_cli.measurements.range import KIND_RANGE, OBSERVABLE as RANGE
from liaison_cli.measurements.registry import predict
from liaison_cli.orbits.catalog import CATALOG
from tests.conftest import LUNAR


def _truth(hours=24.0, n=200):
    times = np.linspace(0.0, hours * 3600.0 / TU_S, n)
    a = dop853_states(CATALOG["eml2_halo"].state(), times, MU)
    b = dop853_states(LUNAR, times, MU)
    return np.stack([a, b], axis=1)  # (m, 2, 6)


def _range(flat):
    g_a, g_b = np.empty(6), np.empty(6)
    value = predict(KIND_RANGE, flat[:6].copy(), flat[6:].copy(), flat[:6].copy(), 0, g_a, g_b, np.empty(6))
    return value, np.concatenate([g_a, g_b])


def test_range_partials_match_central_differences():
    flat = np.concatenate([CATALOG["eml2_halo"].state(), LUNAR])
    analytic = _range(flat)[1]
    numeric = np.empty(12)
    h = 1e-7
    for j in range(12):
        e = np.zeros(12)
        e[j] = h
        numeric[j] = (_range(flat + e)[0] - _range(flat - e)[0]) / (2 * h)
    assert np.allclose(analytic, numeric, rtol=1e-6, atol=1e-9)
    assert np.all(analytic[[3, 4, 5, 9, 10, 11]] == 0.0)


def test_light_time_range_differs_from_geometric_by_minus_range_rate_times_tau():
    truth = _truth()
    ends = [CrtbpTrajectory(truth[:, i], MU) for i in (0, 1)]
    lt = RANGE.simulate(KIND_RANGE, *ends, light_time=True)
    geo = RANGE.simulate(KIND_RANGE, *ends, light_time=False)
    d = truth[:, 1, :3] - truth[:, 0, :3]
    r = np.linalg.norm(d, axis=1)
    rdot = np.sum(d * (truth[:, 1, 3:] - truth[:, 0, 3:]), axis=1) / r
    predicted = -rdot * r / SPEED_OF_LIGHT_LU_TU
    to_m = LU_KM * 1e3
    assert np.max(np.abs(lt - geo)) * to_m > 50.0  # a real, ~0.1-0.2 km effect for this orbiter
    assert np.max(np.abs((lt - geo) - predicted)) * to_m < 0.05  # first-order theory to 5 cm
