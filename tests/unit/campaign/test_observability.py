"""Observability analysis: information matrix algebra, range-rate partials, 001 trends, Taylor STM."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.analysis.observability import analyse, stm_from_t0, taylor_stm_errors
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.dynamics.constants import LU_KM, MU, TU_S
from liaison_cli.measurements.range import geometric_range_gradient
from liaison_cli.measurements.range_rate import range_rate, range_rate_gradient
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.campaign.studies.observability_study import scenario_inputs
from tests.conftest import SCENARIOS, run_cli_in_process

SIGMA_RANGE = 150.0 / (LU_KM * 1e3)
SIGMA_RATE = 1e-3 / (LU_KM * 1e3 / TU_S)


def _inputs(formation):
    scenario, _ = load_scenario(SCENARIOS / f"{formation}.yaml")
    names, states0, times_s, links = scenario_inputs(scenario)
    return names, states0, times_s / TU_S, links


@pytest.fixture(scope="module")
def formations():
    out = {}
    for formation in ("eml2_lunar", "eml1_lunar", "eml1_eml2"):
        names, states0, times, links = _inputs(formation)
        out[formation] = {obs: analyse(states0, times, links, sigma, obs, names)
                          for obs, sigma in (("range", SIGMA_RANGE), ("range_rate", SIGMA_RATE))}
    return out


def test_range_rate_partials_match_central_differences():
    rng = np.random.default_rng(4)
    a = CATALOG["eml2_halo"].state() + rng.normal(0, 1e-3, 6)
    b = CATALOG["eml1_halo"].state() + rng.normal(0, 1e-3, 6)
    grad = range_rate_gradient(a, b)
    for j in range(6):
        h = 1e-6 * max(1.0, abs(a[j]))
        e = np.zeros(6)
        e[j] = h
        numeric = (range_rate(a + e, b) - range_rate(a - e, b)) / (2 * h)
        assert numeric == pytest.approx(grad[j], rel=1e-6, abs=1e-9)
        numeric_t = (range_rate(a, b + e) - range_rate(a, b - e)) / (2 * h)
        assert numeric_t == pytest.approx(-grad[j], rel=1e-6, abs=1e-9)


def test_information_matrix_is_the_sum_of_mapped_partials():
    names, states0, times, links = _inputs("eml2_lunar")
    times = times[:1200]  # 2.6 days: well enough conditioned (cond ~1e11) for a meaningful SVD
    result = analyse(states0, times, links, SIGMA_RANGE, "range", names)
    states, phis = stm_from_t0(states0, times)
    H = []
    for k in range(1, len(times)):
        g = geometric_range_gradient(states[k, 0, :3], states[k, 1, :3])
        row = np.concatenate([np.concatenate([g, np.zeros(3)]) @ phis[k, 0],
                              -np.concatenate([g, np.zeros(3)]) @ phis[k, 1]])
        H.append(row)
    H = np.array(H)
    assert np.allclose(result.information, H.T @ H / SIGMA_RANGE**2, rtol=1e-10)
    assert np.allclose(result.gramian, H.T @ H, rtol=1e-10)
    s = np.linalg.svd(H.T @ H, compute_uv=False)
    assert result.condition_number == pytest.approx(s[0] / s[-1], rel=1e-4)
    assert result.unobservability_index == pytest.approx(SIGMA_RANGE**2 / s[-1], rel=1e-4)


def test_eml1_eml2_is_the_least_observable_formation(formations):
    """001 Table 3 trend: both measures are larger for EML1-EML2 than for either halo-lunar formation."""
    for observable in ("range", "range_rate"):
        worst = formations["eml1_eml2"][observable]
        for other in ("eml2_lunar", "eml1_lunar"):
            assert worst.condition_number > formations[other][observable].condition_number, (observable, other)
            assert worst.unobservability_index > formations[other][observable].unobservability_index


def test_lunar_orbiter_effectiveness_peaks_near_perilune_and_dips_near_apolune(formations):
    names, states0, times, _ = _inputs("eml2_lunar")
    states, _ = stm_from_t0(states0, times)
    distance = np.linalg.norm(states[:, 1, :3] - np.array([1 - MU, 0, 0]), axis=1)
    effectiveness = formations["eml2_lunar"]["range"].effectiveness_position[:, 1]
    peri = np.where((distance[1:-1] < distance[:-2]) & (distance[1:-1] < distance[2:]))[0] + 1
    apo = np.where((distance[1:-1] > distance[:-2]) & (distance[1:-1] > distance[2:]))[0] + 1
    window = 20  # +-62.5 min
    ratios = []
    for p in peri:
        a = apo[np.argmin(np.abs(apo - p))]  # the neighbouring apolune pass
        near_peri = np.nanmax(effectiveness[max(p - window, 1) : p + window])
        near_apo = np.nanmax(effectiveness[max(a - window, 1) : a + window])
        ratios.append(near_peri / near_apo)
    assert len(ratios) >= 10
    assert np.median(ratios) > 2.5 and min(ratios) > 1.5, ratios
    # The halo orbiter's effectiveness grows over the run (000 Fig. 17).
    eml2 = formations["eml2_lunar"]["range"].effectiveness_position[:, 0]
    assert eml2[-1] > 10 * eml2[10]


def test_taylor_stm_error_is_small_and_second_order():
    errors = taylor_stm_errors(CATALOG["eml2_halo"].state(), 1.0 * 86400 / TU_S, (60, 600))
    assert errors[60][0] < 1e-6
    assert 60 < errors[600][0] / errors[60][0] < 140  # ~ (600/60)^2


def test_observability_command_writes_tables_and_plot(tmp_path):
    proc = run_cli_in_process("observability", SCENARIOS / "smoke.yaml", "--output", tmp_path / "o")
    assert proc.returncode == 0, proc.stderr
    assert "condition number" in proc.stdout and "Taylor STM" in proc.stdout
    table = pd.read_parquet(tmp_path / "o" / "effectiveness.parquet")
    assert set(table.observable) == {"range", "range_rate", "gamma_range_rate_over_range"}
    assert set(table.spacecraft) == {"EML2", "Lunar"}
    assert (tmp_path / "o" / "effectiveness.png").stat().st_size > 30_000
    assert len(pd.read_parquet(tmp_path / "o" / "singular.parquet")) == 24
    assert set(pd.read_parquet(tmp_path / "o" / "taylor_stm.parquet").step_s) == {10, 60, 100, 600}


def test_vectorised_partials_equal_the_measurement_models():
    from liaison_cli.analysis.observability import _link_partials

    names, states0, times, links = _inputs("eml2_lunar")
    states, _ = stm_from_t0(states0, times[:50])
    rate_r, rate_t = _link_partials(states, 0, 1, "range_rate")
    rng_r, rng_t = _link_partials(states, 0, 1, "range")
    for k in (0, 17, 49):
        expected = range_rate_gradient(states[k, 0], states[k, 1])
        assert np.allclose(rate_r[k], expected, rtol=1e-12, atol=1e-15)
        assert np.allclose(rate_t[k], -expected, rtol=1e-12, atol=1e-15)
        expected = geometric_range_gradient(states[k, 0, :3], states[k, 1, :3])
        assert np.allclose(rng_r[k, :3], expected, rtol=1e-12) and np.allclose(rng_t[k, :3], -expected, rtol=1e-12)
        assert np.all(rng_r[k, 3:] == 0.0)


def test_gamma_figure_of_merit_scales_with_the_noise_ratio():
    """001 §5.4: gamma = range-rate over range information per epoch, weights included, so dividing the
    range-rate sigma by 10 multiplies gamma by 100; the lunar orbiter gains more from range-rate than EML2."""
    from liaison_cli.campaign.studies.observability_study import observability_study

    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    coarse = observability_study(scenario, 1e-2, taylor=False).summary["gamma_range_rate_over_range"]
    fine = observability_study(scenario, 1e-3, taylor=False).summary["gamma_range_rate_over_range"]
    for a, b in zip(coarse, fine):
        assert b["gamma_position_median"] == pytest.approx(100 * a["gamma_position_median"], rel=1e-9)
    by_name = {row["spacecraft"]: row for row in coarse}
    assert by_name["Lunar"]["gamma_position_median"] > 10 * by_name["EML2"]["gamma_position_median"]
