"""Residual editing (issue 26 item 5): the EKF's pre-fit gate, |y - H dx| > k sqrt(H P H' + R) -> no update.

Outliers are injected into eml2_lunar's drawn measurements (1 % of them, 100 sigma, random sign, seeded per
run). Measured over the 4 runs below: without the gate they raise the position RMS over the 10 days 9.2x
(EML2) and 6.1x (Lunar); with a 5-sigma gate it is within 3 % of the clean runs' (0.976x and 1.000x), and the
gate rejects exactly the 197 injected measurements, no clean one.
"""

from dataclasses import replace
from statistics import NormalDist

import numpy as np
import pandas as pd
import pytest

from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import M_PER_LU, SECONDS_PER_DAY
from liaison_cli.estimation.estimators import estimate
from liaison_cli.estimation.filter_loop import gated
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process

RUNS = 4
OUTLIER_SHARE = 0.01
OUTLIER_SIGMAS = 100.0


@pytest.fixture(scope="module")
def problem():
    scenario, _ = load_scenario(SCENARIOS / "eml2_lunar.yaml")
    return prepare_problem(scenario)


def _with_outliers(problem, y_obs, run):
    """y_obs with OUTLIER_SHARE of its measurements moved by OUTLIER_SIGMAS of their channel's sigma, and
    the (epoch, channel) pairs moved."""
    rng = np.random.default_rng([26, 5, run])
    measured = np.argwhere(np.isfinite(y_obs[1:])) + [1, 0]
    picked = measured[rng.random(len(measured)) < OUTLIER_SHARE]
    signs = rng.choice([-1.0, 1.0], len(picked))
    dirty = y_obs.copy()
    dirty[picked[:, 0], picked[:, 1]] += OUTLIER_SIGMAS * problem.sigma_lu[picked[:, 1]] * signs
    return dirty, {tuple(p) for p in picked}


def _position_rms_m(problem, history):
    """Per spacecraft, the RMS of the 3-D position error over t > 0 and over t >= 1 d (m): (2, n_sc)."""
    n_sc = len(problem.spacecraft)
    err = history.err[:, : 6 * n_sc].reshape(len(problem.times_s), n_sc, 6)[:, :, :3]
    squared = np.sum(err**2, axis=2) * M_PER_LU**2
    spans = (problem.times_s > 0.0, problem.times_s >= SECONDS_PER_DAY)
    return np.array([np.sqrt(np.mean(squared[span], axis=0)) for span in spans])


def _gate(problem, sigma, after=0):
    return replace(problem.filter, residual_gate_sigma=sigma, residual_gate_after=after)


def test_outliers_ruin_the_ungated_filter_and_the_gate_restores_it(problem):
    clean, ruined, edited = [], [], []
    for run in range(RUNS):
        inputs = draw_run_inputs(problem, run)
        dirty, injected = _with_outliers(problem, inputs.y_obs, run)
        base = estimate("ekf", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
        wide = estimate("ekf", _gate(problem, 1e300), inputs.x0_hat, inputs.y_obs, inputs.truth)
        for key in ("err", "sigma", "nees", "innovation", "innovation_std"):  # a gate that never trips: no change
            assert np.array_equal(getattr(base, key), getattr(wide, key), equal_nan=True), key
        assert not wide.rejected.any() and not base.rejected.any()
        outliers = estimate("ekf", problem.filter, inputs.x0_hat, dirty, inputs.truth)
        gated_run = estimate("ekf", _gate(problem, 5.0), inputs.x0_hat, dirty, inputs.truth)
        assert base.ok and outliers.ok and gated_run.ok
        rejected = {tuple(p) for p in np.argwhere(gated_run.rejected)}
        # Every outlier is far outside the gate (100 sigma against at most 1.4 km of spread at the first
        # epoch); a clean measurement beyond 5 sigma has probability 5.7e-7 (0.003 expected per run).
        assert len(injected) > 20 and injected <= rejected, (len(injected), len(injected - rejected))
        assert len(rejected - injected) <= 2, len(rejected - injected)
        clean.append(_position_rms_m(problem, base))
        ruined.append(_position_rms_m(problem, outliers))
        edited.append(_position_rms_m(problem, gated_run))
    clean, ruined, edited = (np.mean(np.square(a), axis=0) ** 0.5 for a in (clean, ruined, edited))
    # Measured, over t > 0 (EML2 / Lunar): clean 617 / 301 m, outliers 5674 / 1827 m, gated 603 / 302 m;
    # after day 1: clean 596 / 194 m, outliers 5895 / 1332 m, gated 579 / 195 m.
    assert np.all(ruined > 3.0 * clean), ruined / clean
    assert np.all(np.abs(edited / clean - 1.0) < 0.10), edited / clean


def test_the_gate_widens_with_the_state_uncertainty_and_waits_for_its_warm_up(problem):
    """At epoch 1 the range's spread sqrt(H P H' + R) is ~1.4 km (P0: 1 km per axis on both craft), late in
    the run ~0.16 km: an 800 m offset (5.3 sigma of the noise alone) passes the 5-sigma gate at epoch 1 and
    is refused at epoch 3000. With a warm-up of 10 accepted measurements (epochs 1-10, one range each), a
    100-sigma outlier at epoch 5 is taken and the same one at epoch 3000 refused. (The outlier taken pulls the
    estimate beyond the gate: the first clean measurements after the warm-up are refused too, 6 here, until
    the covariance catches up; the reason the default warm-up is none.)"""
    inputs = draw_run_inputs(problem, 0)
    sigma_lu = problem.sigma_lu[0]
    offset = inputs.y_obs.copy()
    offset[[1, 3000], 0] += 800.0 / M_PER_LU
    history = estimate("ekf", _gate(problem, 5.0), inputs.x0_hat, offset, inputs.truth)
    assert 800.0 / M_PER_LU > 5.0 * sigma_lu
    assert history.innovation_std[1, 0] * M_PER_LU > 1000.0 and history.innovation_std[3000, 0] * M_PER_LU < 200.0
    assert np.argwhere(history.rejected).tolist() == [[3000, 0]]

    outliers = inputs.y_obs.copy()
    outliers[[5, 3000], 0] += OUTLIER_SIGMAS * sigma_lu
    history = estimate("ekf", _gate(problem, 5.0, after=10), inputs.x0_hat, outliers, inputs.truth)
    assert not history.rejected[:11].any() and history.rejected[3000, 0]
    assert abs(history.innovation[5, 0]) > 5.0 * history.innovation_std[5, 0]  # beyond the gate, but warm-up


def test_clean_data_are_edited_at_the_gaussian_tail_rate(problem):
    """A consistent filter's normalised innovations are N(0, 1): a 3-sigma gate edits 2 (1 - Phi(3)) = 0.27 %
    of clean data (measured: 49 of 18,432, 0.27 %; 49.8 expected). A spread wrong by 10 % either way would
    edit 0.63 % or 0.10 % (116 or 18 here), outside the 3.5-sigma Poisson band asserted."""
    rejected, processed = 0, 0
    for run in range(RUNS):
        inputs = draw_run_inputs(problem, run)
        history = estimate("ekf", _gate(problem, 3.0), inputs.x0_hat, inputs.y_obs, inputs.truth)
        rejected += int(history.rejected.sum())
        processed += int(np.isfinite(history.innovation).sum())
    expected = 2.0 * (1.0 - NormalDist().cdf(3.0)) * processed
    assert abs(rejected - expected) < 3.5 * np.sqrt(expected), (rejected, expected)


def test_gate_threshold_is_strict():
    assert gated(5.0 + 1e-9, 1.0, 5.0, 0, 0) and not gated(5.0, 1.0, 5.0, 0, 0)
    assert not gated(1e9, 1.0, 0.0, 0, 10**6)  # gate off
    assert not gated(1e9, 1.0, 5.0, 3, 2) and gated(1e9, 1.0, 5.0, 3, 3)  # warm-up: 3 accepted first


def test_cli_counts_rejections_per_link(tmp_path):
    path = edited_scenario(tmp_path, "eml2_lunar.yaml", "  rk4_substeps: 4\n",
                           "  rk4_substeps: 4\n  residual_gate_sigma: 3\n")
    out = tmp_path / "out"
    proc = run_cli_in_process("run", path, "--runs", "2", "--jobs", "1", "--float64", "--quiet", "--output", out)
    assert proc.returncode == 0, proc.stderr
    residuals = pd.read_parquet(out / "residuals.parquet")
    summary = pd.read_parquet(out / "summary.parquet")
    per_run = residuals.groupby("run").rejected.sum()
    for run, count in per_run.items():
        assert (summary[summary.run == run].rejected_measurements == count).all()
    assert per_run.sum() > 0
    z = (residuals.innovation.abs() / residuals.innovation_std).to_numpy()
    assert np.all(z[residuals.rejected] > 3.0) and np.all(z[~residuals.rejected & np.isfinite(z)] <= 3.0)
    assert (f"residual gate 3 sigma after 0 accepted: {per_run.sum()} measurements rejected in 2 runs"
            in proc.stdout), proc.stdout


@pytest.mark.parametrize("value", ["0", "-1"])
def test_gate_not_positive_is_one_line_exit_2(tmp_path, value):
    path = edited_scenario(tmp_path, "eml2_lunar.yaml", "  rk4_substeps: 4\n",
                           f"  rk4_substeps: 4\n  residual_gate_sigma: {value}\n")
    proc = run_cli_in_process("run", path, "--output", tmp_path / "out")
    assert_one_line_error(proc, path, ["filter.residual_gate_sigma", f"= {value}", "greater than 0"])
    assert not (tmp_path / "out").exists()


def test_gate_with_the_batch_estimator_is_one_line_exit_2(tmp_path):
    path = edited_scenario(tmp_path, "nrho_earth_station.yaml", "  initial_sigma_velocity_m_s: 0.001\n",
                           "  initial_sigma_velocity_m_s: 0.001\n  residual_gate_sigma: 5\n")
    proc = run_cli_in_process("run", path, "--output", tmp_path / "out")
    assert_one_line_error(proc, path, ["filter.residual_gate_sigma = 5", "estimator: batch", "no residual gate"])
