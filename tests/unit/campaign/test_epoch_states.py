"""states.parquet (output.epoch_states_runs): per-epoch estimate, error and sigma per spacecraft, checked
against the run's other tables and against rotation invariants, and written only when asked for."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.campaign.engine.results import write_campaign
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.storage import read_metadata, units_of_file
from tests.conftest import SCENARIOS, run_cli_in_process


@pytest.fixture(scope="module")
def smoke_folder(tmp_path_factory):
    scenario, text = load_scenario(SCENARIOS / "smoke.yaml")
    scenario = apply_overrides(scenario, {"output.epoch_states_runs": 2})
    result = run_campaign(scenario, runs=3, jobs=1, progress=False)
    out = tmp_path_factory.mktemp("states")
    write_campaign(result, out, text)
    return out


def test_states_cover_the_asked_runs_at_the_covariance_record_epochs(smoke_folder):
    states = pd.read_parquet(smoke_folder / "states.parquet")
    assert sorted(states.run.unique()) == [0, 1]  # runs 0..N-1 only
    timeseries = pd.read_parquet(smoke_folder / "timeseries.parquet")
    assert set(states.t_s) <= set(timeseries.t_s) and 0.0 in set(states.t_s)
    assert list(states.spacecraft.unique()) == ["EML2", "Lunar"]
    # Position error norm = the timeseries' at the same epochs (float32 storage: relative 1e-6).
    merged = states.merge(timeseries, on=["run", "t_s", "spacecraft"])
    norm = np.sqrt(merged.error_x_m.astype(float) ** 2 + merged.error_y_m ** 2 + merged.error_z_m ** 2)
    np.testing.assert_allclose(norm, merged.position_error_m, rtol=1e-5)
    assert states.x_km.dtype == np.float64 and states.error_x_m.dtype == np.float32


def test_ric_errors_and_sigmas_are_rotations_of_the_model_axes(smoke_folder):
    states = pd.read_parquet(smoke_folder / "states.parquet")
    for kind, unit, prefix in (("position", "m", ""), ("velocity", "m_s", "v")):
        ric_error = sum(states[f"error_{a}_{kind}_{unit}"].astype(float) ** 2
                        for a in ("radial", "intrack", "crosstrack"))
        axis_error = sum(states[f"error_{prefix}{a}_{unit}"].astype(float) ** 2 for a in "xyz")
        np.testing.assert_allclose(ric_error, axis_error, rtol=1e-5)
        # The trace of a covariance block does not depend on the axes: the RIC sigmas come from the recorded
        # 3 x 3 block, the axis sigmas from the filter's diagonal.
        ric_var = sum(states[f"sigma_{a}_{kind}_{unit}"].astype(float) ** 2 for a in ("radial", "intrack", "crosstrack"))
        axis_var = sum(states[f"sigma_{prefix}{a}_{unit}"].astype(float) ** 2 for a in "xyz")
        np.testing.assert_allclose(ric_var, axis_var, rtol=1e-5)
        for pair in ("xy", "xz", "yz"):
            corr = states[f"corr_{prefix}{pair}"]
            assert corr.notna().all() and (corr.abs() <= 1.0 + 1e-6).all()


def test_ric_rms_over_settled_epochs_is_the_summary_figure(smoke_folder):
    """The summary's rms_{axis}_position_settled_m is taken over the covariance record's settled epochs, the
    same epochs the table holds, so the table reproduces it."""
    states = pd.read_parquet(smoke_folder / "states.parquet")
    summary = pd.read_parquet(smoke_folder / "summary.parquet")
    settle_s = load_scenario(SCENARIOS / "smoke.yaml")[0].settle_days() * 86400.0
    settled = states[states.t_s >= settle_s]
    assert len(settled)
    for (run, name), rows in settled.groupby(["run", "spacecraft"]):
        row = summary[(summary.run == run) & (summary.spacecraft == name)].iloc[0]
        for axis in ("radial", "intrack", "crosstrack"):
            rms = np.sqrt(np.mean(rows[f"error_{axis}_position_m"].astype(float) ** 2))
            assert rms == pytest.approx(row[f"rms_{axis}_position_settled_m"], rel=1e-5)
            sigma = np.sqrt(np.mean(rows[f"sigma_{axis}_position_m"].astype(float) ** 2))
            assert sigma == pytest.approx(row[f"sigma_{axis}_position_settled_m"], rel=1e-5)


def test_states_carry_units_and_their_frame(smoke_folder):
    units = units_of_file(smoke_folder / "states.parquet")
    assert units["x_km"] == "km" and units["vx_km_s"] == "km/s" and units["t_s"] == "s"
    assert units["error_radial_position_m"] == "m" and units["sigma_crosstrack_velocity_m_s"] == "m/s"
    assert "corr_xy" not in units
    assert "rotating frame" in read_metadata(smoke_folder / "states.parquet")["states_frame"]


def test_no_states_table_unless_asked(tmp_path):
    out = tmp_path / "plain"
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--output", out, "--jobs", "1", "--runs", "1")
    assert proc.returncode == 0, proc.stderr
    assert not (out / "states.parquet").exists()
    asked = tmp_path / "asked"
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--output", asked, "--jobs", "1", "--runs", "2",
                              "--epoch-states", "1")
    assert proc.returncode == 0, proc.stderr
    assert set(pd.read_parquet(asked / "states.parquet").run) == {0}
    assert read_metadata(asked / "summary.parquet")["scenario_effective"]["output"]["epoch_states_runs"] == 1


def test_an_initial_batch_keeps_the_rows_on_the_covariance_record(tmp_path):
    """With filter.initial_batch_hours the EKF's record starts at the handover (here epoch 63, stride 2): the
    table's rows are the recorded epochs, so its RIC sigmas exist and its RMS is still the summary's."""
    scenario, text = load_scenario(SCENARIOS / "smoke.yaml")
    scenario = apply_overrides(scenario, {"output.epoch_states_runs": 1, "measurement.interval_s": 60.0,
                                          "filter.initial_batch_hours": 1.05})
    write_campaign(run_campaign(scenario, runs=1, jobs=1, progress=False), tmp_path, text)
    states = pd.read_parquet(tmp_path / "states.parquet")
    summary = pd.read_parquet(tmp_path / "summary.parquet")
    assert states.t_s.min() == 63 * 60.0 and states.sigma_radial_position_m.notna().all()
    settled = states[states.t_s >= scenario.settle_days() * 86400.0]
    for name, rows in settled.groupby("spacecraft"):
        rms = np.sqrt(np.mean(rows.error_radial_position_m.astype(float) ** 2))
        assert rms == pytest.approx(summary[summary.spacecraft == name].rms_radial_position_settled_m.iloc[0],
                                    rel=1e-5)
