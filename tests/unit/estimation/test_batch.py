"""002: dual one-way observables, clocks and their synchronisation, the RK8 propagator and the batch
least-squares estimator, the NRHO scenarios and the tables."""

import json
import math

import numpy as np
import pytest

from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process
from liaison_cli.analysis.metrics import chi2_quantile
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.clock import allan_deviation_model, simulate_clock
from liaison_cli.dynamics.clock_presets import CLOCK_PRESETS
from liaison_cli.dynamics.constants import LU_KM, M_PER_LU, MU
from liaison_cli.dynamics.integrators.dop853 import dop853_state_stm, dop853_states
from liaison_cli.dynamics.integrators.rk8 import rk8_state, rk8_state_stm
from liaison_cli.estimation.clock_sync import fit_clock_polynomial, sync_errors
from liaison_cli.estimation.estimators import estimate
from liaison_cli.measurements.dual_one_way import (
    KIND_CLOCK_OFFSET,
    KIND_DUAL_RANGE,
    KIND_PSEUDORANGE_IJ,
    KIND_PSEUDORANGE_JI,
)
from liaison_cli.measurements.range import FLAG_LIGHT_TIME
from liaison_cli.measurements.registry import predict
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem

NRHO = SCENARIOS / "nrho_gateway_anchors.yaml"


@pytest.fixture(scope="module")
def nrho_problem():
    """The 002 scenario on its cheapest grid cell (1 T span, 60 min)."""
    scenario, _ = load_scenario(NRHO)
    return prepare_problem(apply_overrides(scenario, {"batch.span_days": 6.59, "measurement.interval_s": 3600}))


@pytest.mark.parametrize("kind", [KIND_PSEUDORANGE_IJ, KIND_PSEUDORANGE_JI, KIND_DUAL_RANGE, KIND_CLOCK_OFFSET])
@pytest.mark.parametrize("flags", [0, FLAG_LIGHT_TIME])
def test_dual_one_way_partials_match_central_differences(kind, flags):
    x_i = CATALOG["nrho_gateway"].state()
    x_j = CATALOG["nrho_anchor_1"].state()
    g_i, g_j = np.empty(6), np.empty(6)
    value = predict(kind, x_i, x_j, x_i, flags, g_i, g_j, np.empty(6))
    assert np.isfinite(value)
    scratch = np.empty(6), np.empty(6), np.empty(6)
    for which, (x, g) in enumerate(((x_i, g_i), (x_j, g_j))):
        for axis in range(6):
            h = 1e-7
            plus, minus = x.copy(), x.copy()
            plus[axis] += h
            minus[axis] -= h
            ends_plus = (plus, x_j) if which == 0 else (x_i, plus)
            ends_minus = (minus, x_j) if which == 0 else (x_i, minus)
            numeric = (predict(kind, *ends_plus, x_i, flags, *scratch) - predict(kind, *ends_minus, x_i, flags, *scratch)) / (2 * h)
            assert g[axis] == pytest.approx(numeric, rel=1e-6, abs=1e-9), (which, axis)


def test_dual_one_way_pair_means_range_and_half_difference_offset():
    """Without light time the two pseudoranges share their geometry: the mean is the range, the half
    difference's geometric part is zero; the two raw channels carry the clocks with opposite signs."""
    x_i, x_j = CATALOG["nrho_gateway"].state(), CATALOG["nrho_anchor_2"].state()
    g = np.empty(6), np.empty(6), np.empty(6)
    rho = np.linalg.norm(x_i[:3] - x_j[:3])
    assert predict(KIND_DUAL_RANGE, x_i, x_j, x_i, 0, *g) == pytest.approx(rho, rel=1e-15)
    assert predict(KIND_CLOCK_OFFSET, x_i, x_j, x_i, 0, *g) == 0.0
    assert predict(KIND_PSEUDORANGE_JI, x_i, x_j, x_i, 0, *g) == pytest.approx(rho, rel=1e-15)
    # With light time the two directions differ by the motion during the flight.
    forward = predict(KIND_PSEUDORANGE_IJ, x_i, x_j, x_i, FLAG_LIGHT_TIME, *g)
    backward = predict(KIND_PSEUDORANGE_JI, x_i, x_j, x_i, FLAG_LIGHT_TIME, *g)
    assert forward != backward
    assert predict(KIND_CLOCK_OFFSET, x_i, x_j, x_i, FLAG_LIGHT_TIME, *g) == pytest.approx(0.5 * (forward - backward))


def test_raw_dual_one_way_puts_both_clocks_on_both_channels(tmp_path):
    """The raw observable in the EKF: rho_ij carries +clock_i -clock_j, rho_ji the reverse; the run is
    consistent (normalised innovations of RMS about 1)."""
    path = edited_scenario(tmp_path, "clock_one_way_eml2_lunar.yaml", "observables: [range, pseudorange]",
                           "observables: [range, dual_one_way]")
    lunar = "    elements: {a_km: 9000, e: 0.4, i_deg: 60, raan_deg: 0, argp_deg: 0, ta_deg: 0}\n"
    assert path.read_text().count(lunar) == 1
    text = path.read_text().replace(
        lunar, lunar + "    clock: {preset: csac, initial_offset_sigma_s: 1.0e-6, initial_frequency_sigma: 1.0e-10}\n"
    ).replace("duration_days: 10", "duration_days: 2")
    path.write_text(text)
    scenario, _ = load_scenario(path)
    problem = prepare_problem(scenario)
    layout = problem.filter.layout
    clock_eml2 = layout.start_of(1, "EML2")
    clock_lunar = layout.start_of(1, "Lunar")
    by_label = {ch.label: c for c, ch in enumerate(problem.channels)}
    mods = problem.filter.channel_mod_index, problem.filter.channel_mod_coeff
    for label, signs in (("pseudorange_ij", {clock_eml2: 1.0, clock_lunar: -1.0}),
                         ("pseudorange_ji", {clock_eml2: -1.0, clock_lunar: 1.0})):
        c = by_label[label]
        got = {int(i): float(k) for i, k in zip(mods[0][c], mods[1][c]) if i >= 0 and i in signs}
        assert got == signs
    inputs = draw_run_inputs(problem, 0)
    history = estimate("ekf", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
    assert history.ok
    late = problem.times_s > 86400
    for c in (by_label["pseudorange_ij"], by_label["pseudorange_ji"]):
        nis = history.innovation[late, c] / history.innovation_std[late, c]
        assert 0.8 < np.sqrt(np.nanmean(nis**2)) < 1.2


def test_rk8_schedule_matches_dop853_and_its_stm_matches_central_differences(nrho_problem):
    """Over two NRHO periods at the scenario's step schedule: position within 1 mm of DOP853 at rtol 1e-13,
    and the STM within 1e-6 (relative to its largest entry) of central differences."""
    x0 = CATALOG["nrho_gateway"].state()
    dt_tu = nrho_problem.filter.dt_tu
    counts = nrho_problem.filter.batch.counts
    times = np.arange(counts.size + 1) * dt_tu
    reference = dop853_states(x0, times, MU, rtol=1e-13, atol=1e-15)
    state, worst = x0.copy(), 0.0
    for k, n in enumerate(counts):
        state = rk8_state(state, dt_tu, int(n), np.array([MU]))
        worst = max(worst, float(np.linalg.norm(state[:3] - reference[k + 1, :3])) * M_PER_LU)
    assert worst < 1e-3
    span = slice(0, 40)
    state, phi = x0.copy(), np.eye(6)
    for n in counts[span]:
        state, step = rk8_state_stm(state, dt_tu, int(n), np.array([MU]))
        phi = step @ phi
    _, phi_ref = dop853_state_stm(x0, [0.0, 40 * dt_tu], MU, rtol=1e-13, atol=1e-15)
    assert np.max(np.abs(phi - phi_ref[-1])) < 1e-6 * np.max(np.abs(phi_ref[-1]))


@pytest.mark.parametrize("jacobian", ["first_iteration", "every_iteration"])
def test_noise_free_batch_returns_the_truth_within_six_iterations(jacobian):
    """002 Table 2's initial errors (100 m, 1 mm/s), noise-free data: the batch converges to the truth."""
    scenario, _ = load_scenario(NRHO)
    problem = prepare_problem(apply_overrides(scenario, {"batch.jacobian": jacobian, "batch.tolerance_m": 1e-5}))
    inputs = draw_run_inputs(problem, 3)
    y = problem.measurements_true.copy()
    history = estimate("batch", problem.filter, inputs.x0_hat, y, inputs.truth)
    assert history.ok and history.extras["iterations"] <= 6
    error_m = np.abs(history.err[0].reshape(3, 6)[:, :3]) * M_PER_LU
    assert error_m.max() < 1e-3
    start_error_m = np.abs((inputs.x0_hat - inputs.truth[0]).reshape(3, 6)[:, :3]) * M_PER_LU
    assert start_error_m.max() > 50  # it really started 100 m away


def test_batch_scatter_matches_its_formal_covariance(nrho_problem):
    """With noise: the epoch estimate's NEES (18 states) lies inside its two-sided 95 % chi-square band in at
    least 90 % of 200 Monte Carlo runs, and the post-fit residual RMS matches each channel's sigma."""
    lo, hi = chi2_quantile(0.025, 18), chi2_quantile(0.975, 18)
    nees, residual_ratio = [], []
    orbit_channels = [c for c, ch in enumerate(nrho_problem.channels) if not ch.measures_clock_offset]
    for run in range(200):
        inputs = draw_run_inputs(nrho_problem, run)
        history = estimate("batch", nrho_problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
        assert history.ok, history.reason
        nees.append(history.nees[0])
        residual_ratio.append(history.extras["residual_rms"][orbit_channels] / nrho_problem.sigma_lu[orbit_channels])
    nees = np.array(nees)
    inside = np.mean((nees >= lo) & (nees <= hi))
    assert inside >= 0.90, inside
    assert np.mean(nees) == pytest.approx(18, rel=0.1)
    assert np.mean(residual_ratio) == pytest.approx(1.0, abs=0.05)


def test_clock_fit_is_exact_on_a_quadratic_and_its_window_rms_follows_the_noise():
    t = np.arange(0, 3 * 3600 + 1, 900.0)
    offsets = 2e-6 - 3e-11 * (t - t[-1]) + 4e-16 * (t - t[-1]) ** 2
    fit = fit_clock_polynomial(t, offsets, 1e-9, t[-1])
    assert np.allclose(fit.coefficients, [2e-6, -3e-11, 4e-16], rtol=1e-9)
    # White offset noise sigma over K epochs: the fitted curve's RMS error over the window is sigma sqrt(3/K).
    rng = np.random.default_rng(4)
    sigma, rms = 3e-9, []
    for _ in range(2000):
        result = sync_errors(t, offsets + sigma * rng.standard_normal(t.size), offsets, sigma, t[-1], 3 * 3600, 0.0)
        rms.append(result["rms_window_s"] ** 2)
    assert math.sqrt(np.mean(rms)) == pytest.approx(sigma * math.sqrt(3 / t.size), rel=0.05)


def test_clock_truth_follows_its_drifts_and_diffusions():
    """002 Eq. 13-16: with drifts mu1, mu2 the mean phase is x0 + (f0 + mu1) t + mu2 t^2 / 2; the spread of
    the phase after n steps is the model's (sigma1^2 t + sigma2^2 t^3 / 3)."""
    rng = np.random.default_rng(5)
    dt, n, mu1, mu2 = 60.0, 200, 1e-11, 1e-15
    sigma1, sigma2 = 1e-11, 1e-14
    t = np.arange(n) * dt
    runs = np.stack([simulate_clock(rng, n, dt, [1e-7, 2e-12], sigma1, sigma2, mu1=mu1, mu2=mu2)[:, 0]
                     for _ in range(2000)])
    expected = 1e-7 + (2e-12 + mu1) * t + mu2 * t**2 / 2
    spread = np.sqrt(sigma1**2 * t[-1] + sigma2**2 * t[-1] ** 3 / 3)
    assert np.mean(runs[:, -1]) == pytest.approx(expected[-1], abs=4 * spread / math.sqrt(2000))
    assert np.std(runs[:, -1]) == pytest.approx(spread, rel=0.06)


def test_clock_presets_reproduce_their_sources():
    uso = CLOCK_PRESETS["uso"]
    assert allan_deviation_model([1.0, 100.0], uso.sigma1_s_per_sqrt_s, uso.sigma2_per_sqrt_s) == pytest.approx(
        [1e-13, 1e-13], rel=0.01)
    csac = CLOCK_PRESETS["csac"]
    assert allan_deviation_model(1.0, csac.sigma1_s_per_sqrt_s, csac.sigma2_per_sqrt_s) == pytest.approx(3e-10)
    assert csac.mu2_per_s * 30 * 86400 == pytest.approx(9e-10)
    ocxo = CLOCK_PRESETS["ocxo"]  # h0 = 2e-25 -> sigma1^2 = h0 / 2; h-2 = 6e-25 -> sigma2^2 = 2 pi^2 h-2
    assert ocxo.sigma1_s_per_sqrt_s**2 == pytest.approx(1e-25)
    assert ocxo.sigma2_per_sqrt_s**2 == pytest.approx(2 * math.pi**2 * 6e-25)
    assert all(p.source for p in CLOCK_PRESETS.values())


def test_nrho_table1_states_nearly_close_after_one_period():
    """002 Table 1's printed states (4-5 digits, the paper's own constants) in our CRTBP: after 1.5112 TU
    each returns within 130 km and 0.5 m/s of itself (Gateway 66 km, anchors 85 and 124 km)."""
    closures = {}
    for name in ("nrho_gateway", "nrho_anchor_1", "nrho_anchor_2"):
        orbit = CATALOG[name]
        end = dop853_states(orbit.state(), [0.0, orbit.period_tu], MU, rtol=1e-13, atol=1e-15)[-1]
        closures[name] = np.linalg.norm(end[:3] - orbit.state()[:3]) * LU_KM
    assert closures["nrho_gateway"] == pytest.approx(66.2, abs=1.0)
    assert max(closures.values()) < 130


def test_nrho_run_reports_prediction_drms_and_clock_sync(tmp_path):
    out = tmp_path / "nrho"
    proc = run_cli_in_process("run", NRHO, "--runs", "2", "--jobs", "1", "--output", out)
    assert proc.returncode == 0, proc.stderr
    assert "batch span 9.885 d + 3 h" in proc.stdout and "clock RMS ns, window" in proc.stdout
    import pandas as pd

    summary = pd.read_parquet(out / "summary.parquet")
    assert (summary.status == "ok").all()
    assert summary.rms_position_prediction_m.between(0.01, 20).all()
    anchors = summary[summary.spacecraft != "Gateway"]
    assert anchors.clock_rms_window_ns.between(0.1, 20).all()
    assert summary[summary.spacecraft == "Gateway"].clock_rms_window_ns.isna().all()
    assert summary.batch_iterations.between(2, 6).all()


def test_sweep_and_tables002_give_both_tables(tmp_path):
    paths = [SCENARIOS / f"{name}.yaml" for name in ("nrho_gateway_anchors", "nrho_gateway_anchors_norr",
                                                       "nrho_earth_station", "nrho_earth_station_norr")]
    out = tmp_path / "sweep"
    proc = run_cli_in_process("sweep", *paths, "--grid", "batch.span_days=6.59", "--grid", "measurement.interval_s=3600",
                   "--runs", "3", "--jobs", "1", "--output", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    proc = run_cli_in_process("tables002", out, "--span", "6.59", "--interval", "3600")
    assert proc.returncode == 0, proc.stderr
    assert "| 1 T (6.59 d) | 60 min |" in proc.stdout and "| 1 T | 60 min | RR |" in proc.stdout
    import pandas as pd

    drms = pd.read_parquet(out / "tables002" / "drms_p90.parquet")
    for column in ("autonomous_RR", "autonomous_NORR", "earth_RR", "earth_NORR"):
        assert np.isfinite(drms[f"{column}_drms_p90_m"]).all()
    assert (out / "tables002" / "drms_histograms.png").stat().st_size > 10_000
    consistency = pd.read_parquet(out / "tables002" / "consistency.parquet")
    assert len(consistency) == 4 * 3 and (consistency.runs_ok == 3).all()  # 4 scenarios x 3 spacecraft
    assert consistency.position_error_to_sigma.between(0.2, 3.0).all() and consistency.nees_in_band_share.notna().all()
    assert "| 1 T | 60 min | autonomous RR | Gateway | 3/3 |" in proc.stdout
    from tests.cli.test_cli_json import _study_rows_are_the_parquets  # --json: the same tables, as rows

    proc = run_cli_in_process("tables002", out, "--span", "6.59", "--interval", "3600", "--output", tmp_path / "t",
                              "--json")
    printed = _study_rows_are_the_parquets(json.loads(proc.stdout), tmp_path / "t", "tables002")
    assert printed["source"] == str(out) and len(printed["files"]) >= 4
    assert [row["autonomous_RR_drms_p90_m"] for row in printed["tables"]["drms_p90"]] == list(drms.autonomous_RR_drms_p90_m)


def test_tables002_consistency_pools_the_runs_that_finished_and_marks_both_sides(tmp_path):
    """A hand-made sweep of two runs: Anchor1's settled errors 3 and 4 m against sigma 1 m give
    sqrt((9 + 16) / 2) = 3.54 (marked '!', optimistic); Gateway's 1 m against 2 m give 0.5 (marked '!',
    pessimistic: the verdict is two-sided). A third run, diverged for one spacecraft, is left out for both (as
    the DRMS tables leave it out)."""
    import json

    import pandas as pd

    from liaison_cli.campaign.studies.tables002 import batch_consistency_table
    from liaison_cli.report.nrho002 import format_batch_consistency

    rows = []
    for run, status, anchor_error in ((0, "ok", 3.0), (1, "ok", 4.0), (2, "diverged", 100.0)):
        for name, error, sigma in (("Anchor1", anchor_error, 1.0), ("Gateway", 1.0, 2.0)):
            rows.append({"point": 0, "scenario": "nrho_gateway_anchors", "batch.span_days": 6.59,
                         "measurement.interval_s": 3600, "run": run, "spacecraft": name,
                         "status": status if name == "Anchor1" else "ok", "rms_position_prediction_m": 1.0,
                         "rms_position_settled_m": error, "sigma_position_settled_m": sigma,
                         "rms_velocity_settled_m_s": error * 1e-3, "sigma_velocity_settled_m_s": sigma * 1e-3,
                         "frac_nees_in_band_settled": 0.9})
    pd.DataFrame(rows).to_parquet(tmp_path / "runs.parquet")
    text = (SCENARIOS / "nrho_gateway_anchors.yaml").read_text()
    (tmp_path / "sweep.json").write_text(json.dumps({"scenarios_yaml": {"nrho_gateway_anchors": text}}))
    table = batch_consistency_table(tmp_path).set_index("spacecraft")
    assert table.loc["Anchor1", "position_error_to_sigma"] == pytest.approx(math.sqrt(12.5))
    assert table.loc["Gateway", "velocity_error_to_sigma"] == pytest.approx(0.5)
    assert list(table.runs_ok) == [2, 2] and list(table.consistent) == [False, False]
    assert "optimistic" in table.loc["Anchor1", "consistency_failed"]
    assert "pessimistic" in table.loc["Gateway", "consistency_failed"]
    text = format_batch_consistency(table.reset_index())
    assert "| 1 T | 60 min | autonomous RR | Anchor1 | 2/3 | 3.536 | 1.000 | 3.54 ! | 3.54 ! | 90 % |" in text
    assert "| Gateway | 2/3 | 1.000 | 2.000 | 0.50 ! | 0.50 ! | 90 % |" in text
    assert "2 of 2 rows fail the consistency verdict" in text


@pytest.mark.parametrize("old,new,fragments", [
    ("    clock: {preset: uso, initial_offset_sigma_s: 1.0e-6, initial_frequency_sigma: 1.0e-11}\n  - name: Anchor2",
     "  - name: Anchor2", ["links[0]", "'Anchor1' has no clock model"]),
    ("clock: {preset: rubidium,", "clock: {preset: hydrogen_maser,",
     ["spacecraft[0].clock.preset", "'hydrogen_maser'", "allowed: tcxo, ocxo, rubidium, uso, csac"]),
    ("  window_hours: 3\n", "  window_hours: 0.5\n", ["clock_sync.window_hours = 0.5", "two measurement intervals"]),
    ("  span_days: 9.885", "  span_days: 14", ["batch.span_days = 14", "longer than the scenario's duration_days"]),
])
def test_bad_002_input_is_one_line(tmp_path, old, new, fragments):
    path = edited_scenario(tmp_path, "nrho_gateway_anchors.yaml", old, new)
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, fragments)


def test_sliding_windows_renew_the_solve_from_the_previous_one():
    """Four 1 T windows renewed every 24 h: each converges, the warm-started ones in fewer iterations than a
    cold start, their epoch NEES stay in a sane range, and the run reports every window's prediction."""
    scenario, _ = load_scenario(NRHO)
    problem = prepare_problem(apply_overrides(scenario, {"batch.span_days": 6.59, "batch.windows": 4,
                                                         "batch.renewal_hours": 24, "measurement.interval_s": 3600}))
    inputs = draw_run_inputs(problem, 0)
    history = estimate("batch", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
    windows = history.extras["windows"]
    assert history.ok and len(windows) == 4 and not np.isnan(history.err).any()
    assert all(w["status"] == "ok" for w in windows)
    assert max(w["iterations"] for w in windows[1:]) < windows[0]["iterations"]
    assert all(0 < w["nees"] < chi2_quantile(0.999, 18) for w in windows)
    assert history.data_end_step == 3 * 24 + problem.filter.batch.n_use - 1


def test_windows_without_renewal_is_one_line(tmp_path):
    path = edited_scenario(tmp_path, "nrho_gateway_anchors.yaml", "  prediction_hours: 3\n",
                           "  prediction_hours: 3\n  windows: 3\n")
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, ["batch", "windows = 3 needs 'renewal_hours'"])


def test_batch_section_without_the_batch_estimator_is_one_line(tmp_path):
    path = edited_scenario(tmp_path, "nrho_gateway_anchors.yaml", "estimator: batch", "estimator: ekf")
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, ["key 'estimator' = 'ekf' with a 'batch' section"])


def test_tables002_and_errors_refuse_what_they_cannot_read(tmp_path):
    proc = run_cli_in_process("tables002", tmp_path)
    assert proc.returncode == 2 and "no runs.parquet here" in proc.stderr and "Traceback" not in proc.stderr
    proc = run_cli_in_process("errors", NRHO)
    assert proc.returncode == 2 and "this scenario's estimator is 'batch'" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
