"""004 items 3-4: the receivers of 004 Table 2 as participants, DOP, bad TDoA input, and `liaison study004`
end to end on a shortened arc."""

import numpy as np
import pandas as pd
import pytest

from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario, run_cli_in_process
from tests.test_docs import ALWAYS, expected_columns
from liaison_cli.campaign.engine import backends
from liaison_cli.campaign.studies import study004
from liaison_cli.analysis.dop import tdoa_dop
from liaison_cli.dynamics.constants import LU_KM, VU_KM_S
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem

HALO = SCENARIOS / "004" / "eml2_halo.yaml"


def test_receivers_of_table_2():
    """GEO receivers stay at 42,164 km moving at 3.075 km/s; the EML1 pair is half a period apart (the two
    spacecraft are far apart, not co-located); the VLBA baseline is about 4,000 km (004: over 4,000 km)."""
    scenario, _ = load_scenario(HALO)
    problem = prepare_problem(apply_overrides(scenario, {"duration_days": 1.0, "filter.initial_batch_hours": None,
                                                         "filter.initial_batch_max_hours": None,
                                                         "filter.settle_days": None}))
    known = dict(zip(["GEO130W", "GEO170W", "L1A", "L1B", "MaunaKea", "OwensValley"],
                     np.moveaxis(problem.filter.known_states, 1, 0)))
    for name in ("GEO130W", "GEO170W"):
        r_km = np.linalg.norm(known[name][:, :3], axis=1) * LU_KM
        v_km_s = np.linalg.norm(known[name][:, 3:6], axis=1) * VU_KM_S  # then the accelerations (tdoa)
        assert np.allclose(r_km, 42164.17, atol=0.5) and np.allclose(v_km_s, 3.0747, atol=1e-3)
    geo_baseline = np.linalg.norm(known["GEO130W"][:, :3] - known["GEO170W"][:, :3], axis=1) * LU_KM
    assert np.allclose(geo_baseline, 2 * 42164.17 * np.sin(np.radians(20.0)), rtol=1e-4)  # 28,842 km
    vlba = np.linalg.norm(known["MaunaKea"][:, :3] - known["OwensValley"][:, :3], axis=1) * LU_KM
    assert 3900 < vlba.min() <= vlba.max() < 4100
    l1 = np.linalg.norm(known["L1A"][:, :3] - known["L1B"][:, :3], axis=1) * LU_KM
    assert l1.min() > 15000  # 004: an effective baseline of 20,000-50,000 km


def test_dop_is_the_inverse_gradient_and_favours_long_baselines():
    tx = np.array([[4.0e5, 1.0e5, 2.0e4]])
    for baseline in (4.0e3, 3.0e4):
        first = np.array([[0.0, -baseline / 2, 6.4e3]])
        second = np.array([[0.0, baseline / 2, 6.4e3]])
        dop = tdoa_dop(first, tx, second)[0]
        u1 = (tx - first) / np.linalg.norm(tx - first)
        u2 = (tx - second) / np.linalg.norm(tx - second)
        assert dop == pytest.approx(1.0 / np.linalg.norm(u2 - u1), rel=1e-9)
        assert dop == pytest.approx(np.linalg.norm(tx) / baseline, rel=0.05)  # far field: range / baseline


@pytest.mark.parametrize("old,new,fragments", [
    ("{receiver: MaunaKea, second_receiver: OwensValley, transponder: TX, observables: [tdoa, fdoa]",
     "{receiver: MaunaKea, transponder: TX, observables: [tdoa, fdoa]",
     ["links[0]", "'tdoa'", "one receiver", "second_receiver"]),
    ("{receiver: GEO130W, second_receiver: GEO170W, transponder: TX,",
     "{receiver: GEO130W, second_receiver: TX, transponder: TX,", ["links[1]", "'TX' is the transmitter and also a receiver"]),
    ("{receiver: L1A, second_receiver: L1B, transponder: TX, observables: [tdoa, fdoa]",
     "{receiver: L1A, second_receiver: L1B, transponder: TX, observables: [range, tdoa]",
     ["links[2]", "'range' is a two-end observable"]),
    ("  tdoa_sigma_ns: 20\n", "", ["tdoa_sigma_ns"]),
    ("{name: GEO130W, role: known, orbit: geostationary, longitude_deg: -130}",
     "{name: GEO130W, orbit: geostationary, longitude_deg: -130}", ["station-kept", "role: known"]),
])
def test_bad_tdoa_input_is_one_line(tmp_path, old, new, fragments):
    path = edited_scenario(tmp_path, "004/eml2_halo.yaml", old, new)
    assert_one_line_error(run_cli_in_process("run", path, "--runs", "1"), path, fragments)


def test_study004_runs_and_the_geo_pair_beats_the_ground_pair(tmp_path):
    """Two days, 2 runs per pair: the table, Parquet (with 004's claims) and figure are written, and the GEO
    pair's 3σ position along the truth ends below the ground pair's (a 7x longer baseline; measured over the
    full 14.75 days: 0.12 km against 1.18 km)."""
    short = tmp_path / "eml2_halo.yaml"
    short.write_text(HALO.read_text().replace("duration_days: 14.75", "duration_days: 2")
                     .replace("initial_batch_max_hours: 96", "initial_batch_max_hours: 24")
                     .replace("settle_days: 6 ", "settle_days: 1 "))
    out = tmp_path / "study"
    proc = run_cli_in_process("study004", short, "--runs", "2", "--jobs", "1", "--output", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    for name in ("summary.parquet", "histories.parquet", "claims.parquet", "table.md", "eml2_halo_3sigma.png"):
        assert (out / name).exists(), name
    history = pd.read_parquet(out / "histories.parquet")
    final = history[history.t_days == history.t_days.max()].set_index("pair").position_3sigma_m
    assert final["GEO130W+GEO170W"] < final["MaunaKea+OwensValley"]
    summary = pd.read_parquet(out / "summary.parquet")
    assert len(summary) == 3 and (summary.measured_share > 0.2).all()
    # The EKF beside LinCov: every run of every pair started from the 1,000 km a priori through the initial
    # batch; the GEO pair converges within the two days (measured over the full arc: 10/10 at 1.6-2.7 d).
    assert (summary.runs == 2).all() and summary.ekf_converged_share.between(0, 1).all()
    assert summary.set_index("pair").ekf_converged_share["GEO130W+GEO170W"] == 1.0
    table = (out / "table.md").read_text()
    assert "EKF converged" in table and "best first, LinCov steady 3σ" in table and "initial batch 12 h" in table
    # 004's claims: one row per claim, in the table and claims.parquet; those on the DRO and the transfer cannot be
    # told from a halo-only study, the halo's get a verdict on each metric (or say why not).
    claims = pd.read_parquet(out / "claims.parquet")
    shipped = study004.claims_004()["claims"]
    assert list(claims.id) == [c["id"] for c in shipped]
    assert all(f"`{c['id']}`" in table for c in shipped) and "LinCov: holds?" in table
    by_id = claims.set_index("id")
    assert (by_id.loc["dro_geo_most_accurate", ["ekf_holds", "lincov_holds"]] == "not computable").all()
    assert by_id.loc["halo_geo_fastest", "lincov_holds"] in ("yes", "no")
    assert by_id.loc["dop_geo_below_ground", "geometry_holds"] in ("yes", "no")
    assert set(claims.columns) == expected_columns("claims", ALWAYS)  # docs/outputs.md documents every column


def test_the_low_energy_transfer_scenario_carries_its_manoeuvre():
    """The scenario is valid and its Delta-v block sits after the transmitter's, burning on day 47.6."""
    from liaison_cli.scenario.setup import burn_step, state_layout

    scenario, _ = load_scenario(SCENARIOS / "004" / "low_energy_transfer.yaml")
    tx = scenario.spacecraft[0]
    assert tx.manoeuvre is not None and burn_step(scenario, tx.manoeuvre) == round(47.6 * 86400 / 300)
    layout = state_layout(scenario)
    assert layout.n == 9 and layout.blocks[1].owner == "dv TX"


# The study's fan-out: resume from finished cells and dask (campaign.studies.study_cells,
# campaign.engine.backends). Here rather than in tests/unit/campaign/test_fanout.py: one worker of the suite then
# compiles 004's dated TDoA kernels once.
def _one_day_halo(tmp_path):
    """004's EML2 halo transmitter over one day (three receiver pairs: three cells)."""
    halo = (SCENARIOS / "004" / "eml2_halo.yaml").read_text()
    short = tmp_path / "eml2_halo.yaml"
    short.write_text(halo.replace("duration_days: 14.75", "duration_days: 1")
                     .replace("initial_batch_max_hours: 96", "initial_batch_max_hours: 12")
                     .replace("settle_days: 6 ", "settle_days: 0.5 "))
    assert short.read_text().count("duration_days: 1\n") == 1
    return short


@pytest.mark.slow  # about 25 s: the LocalCluster's workers start and load the compiled core
def test_a_study_on_dask_writes_the_tables_of_one_process(tmp_path, monkeypatch, sigint_kept):
    """study004 on a dask LocalCluster (one for all its cells, backends.session) and on this process alone:
    byte-identical tables."""
    started = []
    original = backends._dask_client
    monkeypatch.setattr(backends, "_dask_client", lambda *args: started.append(1) or original(*args))
    short = _one_day_halo(tmp_path)
    for label, extra in {"one": ["--jobs", "1"], "dask": ["--jobs", "2", "--backend", "dask"]}.items():
        proc = run_cli_in_process("study004", short, "--runs", "3", *extra, "--quiet", "--output", tmp_path / label)
        assert proc.returncode == 0, proc.stderr
    assert len(started) == 1
    for name in ("summary.parquet", "histories.parquet", "table.md"):
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "dask" / name).read_bytes(), name


def test_an_interrupted_study_resumes_its_missing_cells_and_writes_the_same_bytes(tmp_path, monkeypatch,
                                                                                    sigint_kept):
    """004 over three receiver pairs (three cells), interrupted after its first cell: exit 130 naming the work
    folder; the same command again computes only the two missing cells, and its tables are byte-identical to
    those of a study that was never interrupted."""
    command = ["study004", _one_day_halo(tmp_path), "--runs", "1", "--jobs", "1", "--quiet"]
    assert run_cli_in_process(*command, "--output", tmp_path / "whole").returncode == 0

    original, computed = study004._pair_tables, []

    def interrupted_after_one_cell(scenario, *args):
        if computed:
            raise KeyboardInterrupt
        computed.append(scenario.name)
        return original(scenario, *args)

    monkeypatch.setattr(study004, "_pair_tables", interrupted_after_one_cell)
    proc = run_cli_in_process(*command, "--output", tmp_path / "resumed")
    assert proc.returncode == 130, proc.stderr
    assert f"interrupted: 1 of 3 cells saved in {tmp_path / 'resumed.work'}" in proc.stderr
    assert not (tmp_path / "resumed").exists() and len(list((tmp_path / "resumed.work").glob("*.done"))) == 1

    def counted(scenario, *args):
        computed.append(scenario.name)
        return original(scenario, *args)

    monkeypatch.setattr(study004, "_pair_tables", counted)
    assert run_cli_in_process(*command, "--output", tmp_path / "resumed").returncode == 0
    assert len(computed) == 3 and computed[0] not in computed[1:]  # the finished cell was not recomputed
    for name in ("summary.parquet", "histories.parquet", "table.md"):
        assert (tmp_path / "whole" / name).read_bytes() == (tmp_path / "resumed" / name).read_bytes(), name


def test_study_progress_stays_out_of_a_log(tmp_path):
    """Issue 35: study003 / study004 drew tqdm bars into redirected output; they draw them on a terminal only."""
    proc = run_cli_in_process("study004", _one_day_halo(tmp_path), "--runs", "1", "--jobs", "1",
                              "--output", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    assert "%|" not in proc.stderr and "it/s" not in proc.stderr
