"""004 item 1-2: TDoA / FDoA of one transmitter at two receivers: partials against central differences, the
perpendicular bisector, the noise conversions, and visibility on both signal paths."""

from types import SimpleNamespace

import numpy as np
import pytest

from liaison_cli.dynamics.constants import LU_KM, M_S_PER_VU, MOON_POSITION_LU, SPEED_OF_LIGHT_KM_S
from liaison_cli.dynamics.model import crtbp_model
from liaison_cli.dynamics.constants import MU
from liaison_cli.measurements.range import FLAG_LIGHT_TIME
from liaison_cli.measurements.registry import predict
from liaison_cli.measurements.tdoa import FDOA, KIND_FDOA, KIND_TDOA, SECONDS_PER_LU, TDOA
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.scenario.setup import _visible

RX1 = np.array([0.05, 0.09, 0.0, -0.2, 0.1, 0.0])  # GEO-like distances, LU and LU/TU
RX2 = np.array([-0.08, 0.04, 0.01, -0.1, -0.2, 0.01])
TX = CATALOG["eml2_halo"].state()


@pytest.mark.parametrize("kind", [KIND_TDOA, KIND_FDOA])
@pytest.mark.parametrize("flags", [0, FLAG_LIGHT_TIME])
def test_difference_partials_match_central_differences(kind, flags):
    g = [np.empty(6) for _ in range(3)]
    value = predict(kind, RX1, TX, RX2, flags, g[0], g[1], g[2])
    assert np.isfinite(value)
    scratch = [np.empty(6) for _ in range(3)]
    for which in range(3):
        for axis in range(6):
            h = 1e-7 if axis < 3 else 1e-4  # light-time velocity partials are ~tau: a longer step beats rounding
            ends_plus, ends_minus = [RX1.copy(), TX.copy(), RX2.copy()], [RX1.copy(), TX.copy(), RX2.copy()]
            ends_plus[which][axis] += h
            ends_minus[which][axis] -= h
            numeric = (predict(kind, *ends_plus, flags, *scratch) - predict(kind, *ends_minus, flags, *scratch)) / (2 * h)
            assert g[which][axis] == pytest.approx(numeric, rel=1e-6, abs=1e-10), (which, axis)


def test_tdoa_is_zero_on_the_perpendicular_bisector():
    """Receivers at +-b along x; any transmitter in the y-z plane is equidistant: TDoA = 0 to rounding."""
    g = [np.empty(6) for _ in range(3)]
    first = np.array([0.11, 0.0, 0.0, 0.0, 0.0, 0.0])
    second = np.array([-0.11, 0.0, 0.0, 0.0, 0.0, 0.0])
    for y, z in ((1.0, 0.0), (0.3, -0.8), (-2.0, 5.0)):
        tx = np.array([0.0, y, z, 0.1, 0.2, 0.3])
        assert abs(predict(KIND_TDOA, first, tx, second, 0, *g)) < 1e-15 * np.hypot(y, z)
    # Off the bisector the sign says which receiver hears it first: nearer the first, the second is later.
    tx = np.array([0.05, 1.0, 0.0, 0.0, 0.0, 0.0])
    assert predict(KIND_TDOA, first, tx, second, 0, *g) > 0.0


def test_noise_conversions():
    noise = SimpleNamespace(tdoa_sigma_ns=20.0, fdoa_sigma_hz=0.04, carrier_frequency_hz=2.2e9)
    (sigma_tdoa,) = TDOA.sigma(noise, None)
    assert sigma_tdoa * SECONDS_PER_LU == pytest.approx(20e-9)
    assert sigma_tdoa * LU_KM * 1e3 == pytest.approx(20e-9 * SPEED_OF_LIGHT_KM_S * 1e3)  # 6.0 m of path
    (sigma_fdoa,) = FDOA.sigma(noise, None)
    assert sigma_fdoa * M_S_PER_VU == pytest.approx(0.04 * SPEED_OF_LIGHT_KM_S * 1e3 / 2.2e9)  # 5.45 mm/s


def test_a_transmitter_behind_the_moon_from_one_receiver_gives_no_measurement():
    """Both signal paths must be clear: hidden from the first receiver, the epoch is blanked even though
    the second one sees the transmitter; with both clear it is kept."""
    behind = MOON_POSITION_LU + np.array([0.03, 0.0, 0.0])
    tracks = {"RX1": np.array([[0.5, 0.0, 0.0, 0, 0, 0], [0.5, 0.0, 0.0, 0, 0, 0]]),
              "RX2": np.array([[0.9, 0.3, 0.0, 0, 0, 0], [0.9, 0.3, 0.0, 0, 0, 0]]),
              "TX": np.array([[*behind, 0, 0, 0], [*(behind + [0, 0.2, 0]), 0, 0, 0]])}
    trajectories = {name: SimpleNamespace(states=s) for name, s in tracks.items()}
    link = SimpleNamespace(receiver="RX1", transponder="TX", second_receiver="RX2", occultation=True)
    scenario = SimpleNamespace(ground_stations=[])
    visible = _visible(scenario, link, trajectories, crtbp_model(MU), np.array([0.0, 1.0]))
    assert list(visible) == [False, True]


def test_light_time_paths_solve_the_light_cone():
    """Each path's light time solves |r_i(t) - r_t(t - tau)| = c tau for a transmitter in straight-line
    motion (brentq, independent); the FDoA value is the derivative of that path length in reception time
    (central differences over +-1 s of the ends' motion). In cislunar space the light-time TDoA differs from
    the instantaneous one by tens to hundreds of ns: far above the 20 ns noise, hence the flag."""
    from scipy.optimize import brentq

    from liaison_cli.dynamics.constants import SPEED_OF_LIGHT_LU_TU, TU_S

    g = [np.empty(6) for _ in range(3)]
    c = SPEED_OF_LIGHT_LU_TU

    def path(rx, tx, t):  # receiver and transmitter moved t TU in straight lines
        r_rx, r_tx, v_tx = rx[:3] + rx[3:] * t, tx[:3] + tx[3:] * t, tx[3:]
        tau = brentq(lambda q: np.linalg.norm(r_rx - (r_tx - v_tx * q)) - c * q, 0.0, 10.0, xtol=1e-18)
        return c * tau

    tdoa_lt = predict(KIND_TDOA, RX1, TX, RX2, FLAG_LIGHT_TIME, *g)
    assert tdoa_lt == pytest.approx(path(RX2, TX, 0.0) - path(RX1, TX, 0.0), rel=1e-12, abs=1e-16)
    dt = 1.0 / TU_S
    rate = lambda rx: (path(rx, TX, dt) - path(rx, TX, -dt)) / (2 * dt)  # noqa: E731
    fdoa_lt = predict(KIND_FDOA, RX1, TX, RX2, FLAG_LIGHT_TIME, *g)
    assert fdoa_lt == pytest.approx(rate(RX1) - rate(RX2), rel=1e-7)
    shift_ns = abs(tdoa_lt - predict(KIND_TDOA, RX1, TX, RX2, 0, *g)) * SECONDS_PER_LU * 1e9
    assert 20.0 < shift_ns < 1e4
