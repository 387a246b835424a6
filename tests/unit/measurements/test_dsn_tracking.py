"""003 item 4 and the filter of item 5: DSN sites, one station per epoch by priority, dated occultation by
the moving Moon, the uniform range bias, the filter's reduced force model and Lear's underweighting."""

import numpy as np
import pytest

from tests.conftest import SCENARIOS
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.dsn_sites import DSN_SITES_ECEF_M, dsn_site_geodetic, ecef_to_geodetic
from liaison_cli.dynamics.ground_station import geodetic_to_body_km
from liaison_cli.estimation.ekf import update_scalar
from liaison_cli.measurements.visibility import not_occulted
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem

# IAU Commission 4 list of DSN coordinates (ITRF2005, epoch 2003.0), metres: an independent source.
IAU_COMM4_M = {"goldstone": (-2353621.3873, -4641341.4492, 3677052.2629),
               "canberra": (-4460894.9092, 2682361.5401, -3674748.0458)}
MSL = SCENARIOS / "003" / "msl.yaml"


def test_dsn_sites_round_trip_and_agree_with_a_second_source():
    for name, (_, *xyz) in DSN_SITES_ECEF_M.items():
        lat, lon, height = dsn_site_geodetic(name)
        back_km, _ = geodetic_to_body_km(lat, lon, height)
        assert np.linalg.norm(back_km * 1e3 - np.array(xyz)) < 1e-6, name  # micrometres
        if name in IAU_COMM4_M:
            assert np.linalg.norm(np.array(xyz) - IAU_COMM4_M[name]) < 0.15, name
    lat, lon, height = ecef_to_geodetic(0.0, 0.0, 6356752.314245 + 100.0)  # the pole, 100 m up
    assert lat == pytest.approx(90.0) and height == pytest.approx(100.0, abs=1e-6)


def test_one_station_per_epoch_by_priority():
    """Per spacecraft and epoch at most one prioritised station measures; it is the first one that sees
    it; together they cover every epoch at which any of them sees it."""
    scenario, _ = load_scenario(MSL)
    free = apply_overrides(scenario, {"station_priority": None})
    with_rule, without = prepare_problem(scenario), prepare_problem(free)
    stations = ["Goldstone", "Madrid", "Canberra"]
    for target in ("EML1", "MSL"):
        columns = [next(c for c, ch in enumerate(with_rule.channels)
                        if ch.link_label == f"{st}->{target}" and ch.observable == "range") for st in stations]
        kept = np.isfinite(with_rule.measurements_true[1:, columns])
        seen = np.isfinite(without.measurements_true[1:, columns])
        assert kept.sum(axis=1).max() == 1
        assert np.array_equal(kept.any(axis=1), seen.any(axis=1))
        first = np.argmax(seen, axis=1)
        rows = np.flatnonzero(seen.any(axis=1))
        assert np.all(kept[rows, first[rows]])
        assert seen.sum(axis=1).max() >= 2  # the rule had something to decide


def test_occultation_uses_the_moon_where_it_is_at_each_epoch():
    """A line from the Earth's side to a point behind the Moon is blocked at the epoch the Moon sits on
    it and clear at the next, when the Moon has moved away (per-epoch centres, scaled units)."""
    a = np.array([[-0.5, 0.0, 0.0], [-0.5, 0.0, 0.0]])
    b = np.array([[1.5, 0.0, 0.0], [1.5, 0.0, 0.0]])
    moon = np.array([[1.0, 0.0, 0.0], [1.0, 0.1, 0.0]])
    assert list(not_occulted(a, b, earth_lu=np.array([5.0, 5.0, 5.0]), moon_lu=moon)) == [False, True]
    # A station's site can sit inside the Earth's mean sphere: ground links skip the Earth test.
    inside = np.array([[0.0165, 0.0, 0.0]])
    assert not not_occulted(inside, np.array([[1.0, 1.0, 0.0]]), earth_lu=np.zeros(3), moon_lu=moon[:1])
    assert not_occulted(inside, np.array([[1.0, 1.0, 0.0]]), earth_lu=np.zeros(3), moon_lu=moon[:1],
                        check_earth=False)


def test_uniform_range_biases_have_the_stated_spread():
    scenario, _ = load_scenario(MSL)
    problem = prepare_problem(apply_overrides(scenario, {"duration_days": 0.2}))
    sigma = problem.bias_sigma_lu
    draws = np.array([draw_run_inputs(problem, run).bias_lu for run in range(300)]).ravel() / sigma
    assert np.all(np.abs(draws) <= np.sqrt(3.0))
    assert np.std(draws) == pytest.approx(1.0, abs=0.06)  # 2,100 draws: sampling error ~1.5 %


def test_the_filter_keeps_only_its_bodies():
    """003: the truth has every DE421 body, the filter the Earth, Moon and Sun."""
    from liaison_cli.scenario.dated import dated_model

    scenario, _ = load_scenario(MSL)
    model = dated_model(scenario)
    assert int(model.params[3]) == 10 and int(model.filter_params[3]) == 2
    assert prepare_problem(apply_overrides(scenario, {"duration_days": 0.2})).filter.model_params[3] == 2


def test_underweighted_update_keeps_joseph_covariance_exact():
    """K = P H' / ((1 + beta) H P H' + R); P+ equals (I - K H) P (I - K H)' + K R K' for that gain, and
    beta = 0 is the plain Kalman update."""
    rng = np.random.default_rng(5)
    A = rng.standard_normal((6, 6))
    P = A @ A.T + 6 * np.eye(6)
    H = rng.standard_normal(6)
    R = 0.3
    for beta in (0.0, 0.2, 1.0):
        dx, P_new, innovation, S = update_scalar(np.zeros(6), P, 0.7, H, R, -1, beta)
        K = P @ H / ((1 + beta) * H @ P @ H + R)
        IKH = np.eye(6) - np.outer(K, H)
        assert np.allclose(P_new, IKH @ P @ IKH.T + R * np.outer(K, K), atol=1e-12)
        assert np.allclose(dx, K * 0.7)
        assert S == pytest.approx(H @ P @ H + R)
