"""003 item 5: the three cases of a mission, and `liaison study003` end to end on a shortened mission."""

import re

import pandas as pd

from tests.conftest import SCENARIOS, run_cli_in_process
from liaison_cli.campaign.studies.study003 import CASES, case_scenario
from liaison_cli.scenario.loading import load_scenario

CASSINI = SCENARIOS / "003" / "cassini.yaml"


def test_cases_keep_the_right_links():
    scenario, _ = load_scenario(CASSINI)
    links = {case: {(l.receiver, l.transponder) for l in case_scenario(scenario, "cassini", case).links}
             for case in CASES}
    assert len(links["full"]) == 7
    assert links["dsn_only"] == links["full"] - {("EML1", "Cassini")}
    assert links["liaison_only"] == {("EML1", "Cassini"), ("Goldstone", "EML1"), ("Madrid", "EML1"),
                                     ("Canberra", "EML1")}


def test_study003_runs_and_more_data_means_smaller_covariance(tmp_path):
    """Two days, 3 runs per case: the table, Parquet and figures are written; for the departing spacecraft
    the full set's formal 3D RMS sigma is below each reduced case's (measured at 9 days: about 5x below
    DSN-only and 18x below LiAISON-only for Cassini)."""
    short = tmp_path / "cassini.yaml"
    short.write_text(CASSINI.read_text().replace("duration_days: 9", "duration_days: 2"))
    out = tmp_path / "study"
    proc = run_cli_in_process("study003", short, "--runs", "3", "--jobs", "1", "--output", out, "--quiet",
                   "--grid", "filter.underweighting=0,0.2")
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"\| cassini \| DSN \+ LiAISON \| Cassini( !)? \|", proc.stdout)
    # The tuning the numbers depend on is in the header, and each grid point has its own table.
    assert "underweighting beta" in proc.stdout and "SNC sigma_a" in proc.stdout
    assert "**filter.underweighting = 0.0**" in proc.stdout and "**filter.underweighting = 0.2**" in proc.stdout
    for name in ("summary.parquet", "histories.parquet", "table.md", "cassini_histories.png",
                 "departures_position_error.png"):
        assert (out / name).exists(), name
    summary = pd.read_parquet(out / "summary.parquet")
    for _, point in summary.groupby("filter.underweighting"):
        departure = point[point.role == "departure"].set_index("case").sigma3d_rms_position_m
        assert departure["full"] < departure["dsn_only"] and departure["full"] < departure["liaison_only"]
    assert (summary.runs_ok == 3).all()
    assert {"error_to_sigma_position_settled", "frac_nees_in_band_settled", "consistent_settled"} <= set(summary)


def test_both_readings_of_003s_dsn_noise_set_every_ground_link():
    from liaison_cli.campaign.studies.study003 import DSN_NOISE_READINGS, with_dsn_noise
    from liaison_cli.scenario.loading import load_scenario

    scenario, _ = load_scenario(CASSINI)
    text = with_dsn_noise(scenario, "text")
    stations = {st.name for st in scenario.ground_stations}
    ground = [link for link in text.links if {link.receiver, link.transponder} & stations]
    assert ground and all((link.noise.sigma_m, link.noise.range_rate_sigma_m_s) == DSN_NOISE_READINGS["text"]
                          for link in ground)
    crosslinks = [link for link in text.links if not {link.receiver, link.transponder} & stations]
    assert [link.noise for link in crosslinks] == [link.noise for link in scenario.links
                                                   if not {link.receiver, link.transponder} & stations]


def test_a_missions_cases_fly_its_trajectories_once(monkeypatch):
    """The three cases differ only in their links: the study propagates (and corrects) a mission's
    trajectories once, and a case read from the shared truth gets what it would have flown on its own."""
    import numpy as np

    from liaison_cli.campaign.studies import study003
    from liaison_cli.scenario import setup, truth
    from liaison_cli.scenario.loading import apply_overrides

    scenario, _ = load_scenario(CASSINI)
    short = apply_overrides(scenario, {"duration_days": 2})
    flown = []
    real = truth._trajectories
    monkeypatch.setattr(truth, "_trajectories", lambda *args: flown.append(args[0].name) or real(*args))
    summary, _, scenarios = study003.run_study([("cassini", short)], runs=1, jobs=1, progress=False)
    assert len(flown) == 1 and len(summary) == 2 * len(CASES)
    shared: dict = {}
    setup.prepare_problem(scenarios[(0, "cassini", "full")], shared)
    from_shared = setup.prepare_problem(scenarios[(0, "cassini", "liaison_only")], shared)
    alone = setup.prepare_problem(scenarios[(0, "cassini", "liaison_only")])
    assert len(flown) == 3  # the full set's flight, then the case alone; the shared one read the cache
    assert np.array_equal(from_shared.truth, alone.truth)
    assert np.array_equal(from_shared.measurements_true, alone.measurements_true, equal_nan=True)
