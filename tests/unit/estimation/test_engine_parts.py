"""The engine's parts (issue 11): pseudorange + clock, ground stations, known participants, visibility."""

import numpy as np
import pytest

from liaison_cli.campaign.engine import results as results_module
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.dynamics.clock import clock_process_noise, clock_transition, simulate_clock
from liaison_cli.dynamics.constants import EARTH_POSITION_LU, LU_KM, TU_S, WGS84_EQUATORIAL_RADIUS_KM
from liaison_cli.dynamics.ground_station import EARTH_RATE_IN_ROTATING_FRAME_RAD_TU, GroundStationTrajectory
from liaison_cli.measurements.pseudorange import KIND_PSEUDORANGE
from liaison_cli.measurements.range import FLAG_LIGHT_TIME
from liaison_cli.measurements.registry import predict
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import LUNAR, SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process

# The truth spacecraft feel no unmodelled acceleration, so matched models mean no SNC in the filter (with
# SNC the filter is conservative and its NEES sinks below the band over days); the clocks' Q is matched.
MATCHED_DYNAMICS = {"filter.process_noise_accel_m_s2": 0.0, "spacecraft.1.process_noise_accel_m_s2": 0.0}


def _pseudorange(flat, flags):
    g_r, g_t = np.empty(6), np.empty(6)
    value = predict(KIND_PSEUDORANGE, flat[:6].copy(), flat[6:].copy(), flat[:6].copy(), flags, g_r, g_t, np.empty(6))
    return value, np.concatenate([g_r, g_t])


@pytest.mark.parametrize("flags", [0, FLAG_LIGHT_TIME])
def test_pseudorange_partials_match_central_differences(flags):
    # With the light-time term the partials include the term's own (v_T,inertial / c, d / c): exact.
    flat = np.concatenate([CATALOG["eml2_halo"].state(), LUNAR])
    analytic = _pseudorange(flat, flags)[1]
    numeric = np.empty(12)
    for j in range(12):
        e = np.zeros(12)
        e[j] = 1e-7
        numeric[j] = (_pseudorange(flat + e, flags)[0] - _pseudorange(flat - e, flags)[0]) / 2e-7
    assert np.allclose(analytic, numeric, rtol=1e-6, atol=1e-10)
    assert np.all(analytic[[3, 4, 5]] == 0.0)  # the receiver's velocity does not enter
    assert np.any(analytic[[9, 10, 11]] != 0.0) == bool(flags)  # the transmitter's does, through light time


def test_clock_states_enter_the_filter_as_modifiers_with_unit_partials():
    scenario, _ = load_scenario(SCENARIOS / "clock_one_way_eml2_lunar.yaml")
    problem = prepare_problem(apply_overrides(scenario, {"duration_days": 0.1}))
    f = problem.filter
    assert f.layout.n == 14 and [b.kind for b in f.layout.blocks] == [0, 0, 1]
    labels = [ch.label for ch in problem.channels]
    assert labels == ["range", "pseudorange"]
    pseudo = labels.index("pseudorange")
    assert list(f.channel_mod_index[pseudo]) == [12, -1, -1] and f.channel_mod_coeff[pseudo, 0] == 1.0
    assert list(f.channel_mod_index[labels.index("range")]) == [-1, -1, -1]  # two-way: clocks cancel


def test_simulated_clock_increments_match_the_model_covariance():
    rng = np.random.default_rng(4)
    dt, sigma1, sigma2 = 60.0, 3e-10, 1e-11
    runs = np.stack([simulate_clock(rng, 3, dt, [0.0, 0.0], sigma1, sigma2) for _ in range(20000)])
    phi = clock_transition(dt)
    w = runs[:, 2] - runs[:, 1] @ phi.T  # one step's process noise
    empirical = np.cov(w.T)
    model = clock_process_noise(dt, sigma1, sigma2)
    assert np.allclose(empirical, model, rtol=0.05, atol=0.03 * np.sqrt(np.outer(np.diag(model), np.diag(model))))
    # Allan variance at tau = dt of the frequency integrated over the step: sigma1^2/tau + sigma2^2 tau/3.
    assert model[0, 0] / dt**2 == pytest.approx(sigma1**2 / dt + sigma2**2 * dt / 3.0)


def test_clock_filter_is_consistent_with_matched_models():
    scenario, _ = load_scenario(SCENARIOS / "clock_one_way_eml2_lunar.yaml")
    scenario = apply_overrides(scenario, {
        "duration_days": 1.25, "initial_error.draw": "from_covariance", "measurement.light_time": False,
        "filter.range_model": "geometric", "monte_carlo.runs": 30, **MATCHED_DYNAMICS})
    result = run_campaign(scenario, jobs=2, progress=False)
    table = results_module.consistency_table(result)
    assert table.state_size.iloc[0] == 14  # two spacecraft + the clock's phase and frequency
    assert table[table.t_s > 0].inside_band.mean() >= 0.90


def test_ground_station_kinematics():
    times = np.linspace(0.0, 2.0 * np.pi / abs(EARTH_RATE_IN_ROTATING_FRAME_RAD_TU), 400)
    station = GroundStationTrajectory(0.0, 30.0, 0.0, times)
    rel = station.states[:, :3] - np.array(EARTH_POSITION_LU)
    assert np.allclose(np.linalg.norm(rel, axis=1) * LU_KM, WGS84_EQUATORIAL_RADIUS_KM)  # on the equator
    assert np.allclose(station.states[-1, :3], station.states[0, :3], atol=1e-12)  # one turn in the rotating frame
    velocity = np.gradient(station.states[:, :3], times, axis=0, edge_order=2)
    assert np.allclose(velocity[5:-5], station.states[5:-5, 3:], rtol=1e-3, atol=1e-9)
    assert np.allclose(station.inertial_position_before(np.zeros(len(times))), station.states[:, :3])
    speed_m_s = np.linalg.norm(station.states[0, 3:]) * LU_KM * 1e3 / TU_S
    # The equator moves at (sidereal rate - the frame's 1 rad/TU) x the equatorial radius: ~448 m/s.
    assert speed_m_s == pytest.approx((7.2921150e-5 - 1.0 / TU_S) * WGS84_EQUATORIAL_RADIUS_KM * 1e3, rel=1e-9)


def test_elevation_mask_blanks_low_epochs_and_nothing_else():
    scenario, _ = load_scenario(SCENARIOS / "ground_eml2.yaml")
    scenario = apply_overrides(scenario, {"duration_days": 2.0})
    problem = prepare_problem(scenario)
    station = GroundStationTrajectory(35.4267, 0.0, 1000.0, problem.times_s / TU_S)
    d = problem.truth[:, :3] - station.states[:, :3]
    elevation = np.degrees(np.arcsin(np.einsum("ij,ij->i", d / np.linalg.norm(d, axis=1)[:, None], station.up)))
    seen = np.isfinite(problem.measurements_true[1:, 0])
    assert np.array_equal(seen, elevation[1:] >= 10.0)
    assert 0.2 < seen.mean() < 0.8  # the station sees EML2 part of each day


def test_ground_tracking_innovations_are_consistent(tmp_path):
    proc = run_cli_in_process("run", SCENARIOS / "ground_eml2.yaml", "--runs", "2", "--output", tmp_path / "g")
    assert proc.returncode == 0, proc.stderr
    import pandas as pd

    residuals = pd.read_parquet(tmp_path / "g" / "residuals.parquet").dropna()
    for observable, group in residuals.groupby("observable"):
        z = group.innovation / group.innovation_std
        assert 0.9 < np.sqrt(np.mean(z**2)) < 1.1, observable


def test_a_known_partner_is_not_estimated_and_tightens_the_covariance():
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    scenario = apply_overrides(scenario, {"measurement.light_time": False})
    known = apply_overrides(scenario, {"spacecraft.1.role": "known"})
    problem = prepare_problem(known)
    assert problem.filter.layout.n == 6 and problem.spacecraft == ("EML2",)
    assert list(problem.filter.channel_ends[0]) == [0, -1, -1, 0, -1, -1]  # no second receiver
    both = run_campaign(scenario, jobs=1, progress=False).outcomes[0]
    alone = run_campaign(known, jobs=1, progress=False).outcomes[0]
    # Knowing the partner removes its uncertainty from every range: EML2's formal sigma can only shrink.
    sigma_both = both.norms["position_3sigma_m"][1:, 0]
    sigma_alone = alone.norms["position_3sigma_m"][1:, 0]
    assert np.all(sigma_alone <= sigma_both * (1 + 1e-9)) and sigma_alone[-1] < 0.9 * sigma_both[-1]
    assert alone.summary[0]["frac_in_3sigma_after_day1"] > 0.97


@pytest.mark.parametrize("source,old,new,fragments", [
    ("clock_one_way_eml2_lunar.yaml", "    clock:\n      sigma1_s_per_sqrt_s: 3.0e-10\n      sigma2_per_sqrt_s: 1.0e-13\n"
     "      initial_offset_sigma_s: 1.0e-6\n      initial_frequency_sigma: 1.0e-10\n", "",
     ["links[0]", "pseudorange", "'EML2' has no clock"]),
    ("ground_eml2.yaml", "latitude_deg: 35.4267", "latitude_deg: 95", ["ground_stations[0].latitude_deg", "95"]),
    ("ground_eml2.yaml", "elevation_mask_deg: 10}", "elevation_mask_deg: 90}", ["elevation_mask_deg", "90"]),
    ("ground_eml2.yaml", "  - name: EML2\n    orbit: eml2_halo\n",
     "  - name: EML2\n    orbit: eml2_halo\n    role: known\n  - name: Other\n    orbit: eml1_halo\n",
     ["links[0] joins two known participants"]),
    ("ground_eml2.yaml", "transponder: EML2", "transponder: Madrid", ["links[0].transponder", "'Madrid'"]),
])
def test_bad_input_for_the_new_parts_is_one_line(tmp_path, source, old, new, fragments):
    path = edited_scenario(tmp_path, source, old, new)
    proc = run_cli_in_process("run", path, "--output", tmp_path / "out")
    assert_one_line_error(proc, path, fragments)


def test_pn_chip_rate_offset_adds_the_eq2_bias_to_the_truth():
    import yaml

    from liaison_cli.dynamics.constants import M_PER_LU
    from liaison_cli.errors import ScenarioError
    from liaison_cli.radio.ranging import pn_chip_rate_bias_m

    link = yaml.safe_load((SCENARIOS / "links" / "table2_with_ranging_clock.yaml").read_text())
    noise = {k: link[k] for k in ("link_budget", "correlator_integration_s", "ranging_clock_hz", "loop_bandwidth_hz",
                                  "ranging_power_fraction_db")}
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    pn = apply_overrides(scenario, {"noise": {**noise, "ranging_method": "pn", "pn_chip_rate_offset_hz": 2.0}})
    problem = prepare_problem(pn)
    expected_m = pn_chip_rate_bias_m(1e6, 2.0, 0.3)
    assert expected_m == pytest.approx(2.0 * 0.3 * 299792458.0 / 4e6)
    assert problem.bias_lu * M_PER_LU == pytest.approx(expected_m, rel=1e-12)
    with pytest.raises(ScenarioError, match="pn_chip_rate_offset_hz"):
        apply_overrides(scenario, {"noise.pn_chip_rate_offset_hz": 1.0})


def test_clock_errors_are_written_and_sit_inside_their_sigma(tmp_path):
    import pandas as pd

    path = edited_scenario(tmp_path, "clock_one_way_eml2_lunar.yaml", "duration_days: 10", "duration_days: 2")
    proc = run_cli_in_process("run", path, "--runs", "2", "--output", tmp_path / "c")
    assert proc.returncode == 0, proc.stderr
    clocks = pd.read_parquet(tmp_path / "c" / "clocks.parquet")
    assert set(clocks.clock) == {"EML2"} and clocks.run.nunique() == 2
    late = clocks[clocks.t_s >= 86400.0]
    assert (late.phase_error_ns.abs() <= 3 * late.phase_sigma_ns).mean() > 0.97
    assert (late.frequency_error.abs() <= 3 * late.frequency_sigma).mean() > 0.97
    assert late.phase_sigma_ns.max() < 1000.0  # the filter has pulled the 1 microsecond a-priori in


@pytest.mark.slow
@pytest.mark.parametrize("days,runs", [(10.0, 100)])
def test_clock_filter_consistency_long_study(days, runs):
    """The full-length version of test_clock_filter_is_consistent_with_matched_models (pytest -m slow)."""
    scenario, _ = load_scenario(SCENARIOS / "clock_one_way_eml2_lunar.yaml")
    scenario = apply_overrides(scenario, {
        "duration_days": days, "initial_error.draw": "from_covariance", "measurement.light_time": False,
        "filter.range_model": "geometric", "monte_carlo.runs": runs, **MATCHED_DYNAMICS})
    table = results_module.consistency_table(run_campaign(scenario, jobs=2, progress=False))
    assert table.runs.iloc[0] == runs
    assert table[table.t_s > 0].inside_band.mean() >= 0.90


def test_occultation_blanks_exactly_the_epochs_the_moon_blocks():
    from liaison_cli.dynamics.constants import MOON_POSITION_LU, MOON_RADIUS_KM

    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    open_sky = prepare_problem(scenario)
    blocked = prepare_problem(apply_overrides(scenario, {"links.0.occultation": True}))
    a, b = open_sky.truth[:, 0:3], open_sky.truth[:, 6:9]
    # Independent check: distance from the Moon's centre to the segment, sampled at 2,001 points.
    s = np.linspace(0.0, 1.0, 2001)[None, :, None]
    points = a[:, None, :] + s * (b - a)[:, None, :]
    clearance_km = np.min(np.linalg.norm(points - np.array(MOON_POSITION_LU), axis=2), axis=1) * LU_KM
    hidden = clearance_km[1:] <= MOON_RADIUS_KM
    assert 0.02 < hidden.mean() < 0.5  # the orbiter passes behind the Moon every revolution
    assert np.array_equal(np.isnan(blocked.measurements_true[1:, 0]), hidden)
    assert np.isfinite(open_sky.measurements_true[1:, 0]).all()


@pytest.mark.parametrize("dof", [1, 2, 3, 6, 12, 13, 24, 120, 1_200, 12_000, 120_000])
def test_chi_square_quantiles_match_scipy(dof):
    """The pure-Python chi-square quantile (no scipy.special at start-up) against scipy.stats.chi2.ppf."""
    from scipy.stats import chi2

    from liaison_cli.analysis.metrics import chi2_quantile

    for probability in (1e-6, 0.001, 0.025, 0.3, 0.5, 0.7, 0.975, 0.999, 1 - 1e-6):
        assert chi2_quantile(probability, dof) == pytest.approx(chi2.ppf(probability, dof), rel=1e-11)


@pytest.mark.parametrize("dof", [1.2e6, 1.2e7])
def test_chi_square_quantiles_for_a_million_runs(dof):
    """The NEES band of a million-run campaign (12 states) at the probabilities liaison uses."""
    from scipy.stats import chi2

    from liaison_cli.analysis.metrics import chi2_quantile

    for probability in (0.025, 0.975, 0.999):
        assert chi2_quantile(probability, dof) == pytest.approx(chi2.ppf(probability, dof), rel=1e-11)


def test_summary_columns_are_typed_as_a_data_frame_would_type_them():
    """`liaison run` writes its summary without pandas; the file reads back as the DataFrame of its rows."""
    import pandas as pd

    rows = [{"run": 0, "spacecraft": "A", "rms_position_m": 1.5, "status": "ok", "reason": "", "steps": 3,
             "flag": True},
            {"run": 0, "spacecraft": "B", "rms_position_m": float("nan"), "status": "ok", "reason": "",
             "steps": 4, "flag": False, "clock_rms_window_ns": 2.0},
            {"run": 1, "spacecraft": "A", "status": "diverged", "reason": "NEES", "steps": 5, "flag": True,
             "label": "x"}]
    columns = results_module.summary_columns(rows)
    expected = pd.DataFrame(rows).astype({"run": "int32"})
    assert list(columns) == list(expected.columns)
    got = pd.DataFrame(columns)
    for name in expected.columns:
        if not (pd.api.types.is_numeric_dtype(expected[name]) or pd.api.types.is_bool_dtype(expected[name])):
            assert [None if v is None or v != v else v for v in got[name]] == \
                   [None if v is None or v != v else v for v in expected[name]], name
        else:
            assert got[name].dtype == expected[name].dtype, name
            np.testing.assert_array_equal(got[name].to_numpy(), expected[name].to_numpy(), err_msg=name)
