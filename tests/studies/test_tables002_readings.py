"""002's two readings of the links (issue 34, item 8): the shipped scenarios link the Gateway with each anchor
(2 crosslinks); the nrho_gateway_anchors_mesh* scenarios add the anchor <-> anchor link (3 crosslinks), and
`liaison tables002` prints both readings per cell with their ratio (mesh / shipped)."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.scenario.loading import load_scenario
from tests.conftest import SCENARIOS, run_cli_in_process

AUTONOMOUS = ("nrho_gateway_anchors", "nrho_gateway_anchors_norr", "nrho_gateway_anchors_mesh",
              "nrho_gateway_anchors_mesh_norr")


@pytest.mark.parametrize("shipped", ["nrho_gateway_anchors", "nrho_gateway_anchors_norr"])
def test_the_mesh_scenario_is_the_shipped_one_with_the_anchor_link_added(shipped):
    """Three crosslinks, one per pair of spacecraft, with the shipped links' observables; the added link comes
    last (clock_sync keeps each anchor's clock against the Gateway's); nothing else differs."""
    star, _ = load_scenario(SCENARIOS / f"{shipped}.yaml")
    mesh, _ = load_scenario(SCENARIOS / f"{shipped.replace('anchors', 'anchors_mesh')}.yaml")
    pairs = [frozenset((link.receiver, link.transponder)) for link in mesh.links]
    assert len(mesh.links) == 3 and len(set(pairs)) == 3 and len(star.links) == 2
    assert pairs[2] == {"Anchor1", "Anchor2"} and mesh.links[:2] == star.links
    assert mesh.links[2].observables == star.links[0].observables
    assert all(spacecraft.clock is not None for spacecraft in mesh.spacecraft)  # dual one-way needs both clocks
    differ = {key for key, value in mesh.model_dump().items() if star.model_dump()[key] != value}
    assert differ == {"name", "description", "links"}


def _one_cell_tables(tmp_path, names):
    """2 runs of the 1 T / 60 min cell of the named scenarios, swept and tabulated: (sweep folder, tables002's
    completed process)."""
    out = tmp_path / "sweep"
    proc = run_cli_in_process("sweep", *(SCENARIOS / f"{name}.yaml" for name in names),
                              "--grid", "batch.span_days=6.59", "--grid", "measurement.interval_s=3600",
                              "--runs", "2", "--jobs", "1", "--output", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    proc = run_cli_in_process("tables002", out, "--span", "6.59", "--interval", "3600")
    assert proc.returncode == 0, proc.stderr
    return out, proc


def test_tables002_prints_and_writes_both_readings_and_their_ratio(tmp_path):
    """2 runs of one grid cell for the four autonomous scenarios: the readings table is printed and written
    (readings.md, tables.md), and the Parquet ratios are the mesh p90 over the shipped p90 of per_run.parquet."""
    out, proc = _one_cell_tables(tmp_path, AUTONOMOUS)
    tables = out / "tables002"
    readings = (tables / "readings.md").read_text()
    assert readings in proc.stdout and readings in (tables / "tables.md").read_text()
    assert "| span | interval | NORR shipped | NORR + anchor link | NORR ratio |" in readings
    assert "withheld from our copy of the paper" in readings
    assert "| 1 T | 60 min | autonomous RR + anchor link | Gateway | 2/2 |" in proc.stdout  # consistency rows

    per_run = pd.read_parquet(tables / "per_run.parquet")
    assert set(per_run.reading) == {"star", "mesh"}
    assert set(per_run[per_run.reading == "mesh"].scenario) == set(AUTONOMOUS[2:])
    drms = pd.read_parquet(tables / "drms_p90.parquet").iloc[0]
    clocks = pd.read_parquet(tables / "clock_p90.parquet").set_index("measurements")
    for measurements in ("NORR", "RR"):
        runs = per_run[(per_run.measurements == measurements) & (per_run.status == "ok")]
        star = np.quantile(runs[runs.reading == "star"].drms_mean_m, 0.9)
        mesh = np.quantile(runs[runs.reading == "mesh"].drms_mean_m, 0.9)
        assert drms[f"autonomous_{measurements}_drms_p90_m"] == pytest.approx(star, rel=1e-12)
        assert drms[f"autonomous_mesh_{measurements}_drms_p90_m"] == pytest.approx(mesh, rel=1e-12)
        assert drms[f"autonomous_{measurements}_mesh_ratio"] == pytest.approx(mesh / star, rel=1e-12)
        assert drms[f"autonomous_mesh_{measurements}_runs_ok"] == 2
        assert f"| {star:.3f} | {mesh:.3f} | {mesh / star:.2f} |" in readings
        row = clocks.loc[measurements]
        for which in ("window", "prediction"):
            values = {reading: runs[runs.reading == reading].filter(like=f"clock_{which}_").to_numpy().ravel()
                      for reading in ("star", "mesh")}
            p90 = {reading: np.quantile(v[np.isfinite(v)], 0.9) for reading, v in values.items()}
            assert row[f"clock_{which}_mesh_ratio"] == pytest.approx(p90["mesh"] / p90["star"], rel=1e-12)
        assert row.mesh_runs_ok == 2 and row.runs_ok == 2


@pytest.mark.parametrize("shipped", ["nrho_earth_station", "nrho_earth_station_norr"])
def test_the_always_visible_station_is_the_shipped_one_without_horizon_or_occultation(shipped):
    """002's second station reading: the same file with no elevation mask (-90) and no occultation; nothing else
    differs. Its truth has a measurement at every epoch, the shipped one at a share of them."""
    from liaison_cli.campaign.studies.tables002 import STAR, VISIBLE, _reading
    from liaison_cli.scenario.setup import prepare_problem

    station, _ = load_scenario(SCENARIOS / f"{shipped}.yaml")
    visible, _ = load_scenario(SCENARIOS / f"{shipped.replace('station', 'station_visible')}.yaml")
    assert visible.ground_stations[0].elevation_mask_deg == -90 and not any(l.occultation for l in visible.links)
    differ = {key for key, value in visible.model_dump().items() if station.model_dump()[key] != value}
    assert differ == {"name", "description", "links", "ground_stations"}
    assert (_reading(station), _reading(visible)) == (STAR, VISIBLE)
    seen = np.isfinite(prepare_problem(visible).measurements_true[1:]).mean()
    shipped_seen = np.isfinite(prepare_problem(station).measurements_true[1:]).mean()
    assert seen == 1.0 and shipped_seen < 0.7


def test_tables002_prints_both_station_readings_and_their_ratio(tmp_path):
    """2 runs of one cell of the four Earth-based scenarios: the station readings table, and the Parquet ratio
    equal to the visible p90 over the shipped p90."""
    names = ("nrho_earth_station", "nrho_earth_station_norr", "nrho_earth_station_visible",
             "nrho_earth_station_visible_norr")
    out, proc = _one_cell_tables(tmp_path, names)
    readings = (out / "tables002" / "readings.md").read_text()
    assert "| span | interval | NORR shipped | NORR always visible | NORR ratio |" in readings
    drms = pd.read_parquet(out / "tables002" / "drms_p90.parquet").iloc[0]
    for measurements in ("RR", "NORR"):
        assert drms[f"earth_{measurements}_visible_ratio"] == pytest.approx(
            drms[f"earth_visible_{measurements}_drms_p90_m"] / drms[f"earth_{measurements}_drms_p90_m"])
