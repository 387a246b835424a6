"""003 item 5: the three cases of a mission, and `liaison study003` end to end on a shortened mission."""

import pandas as pd

from conftest import SCENARIOS, run_cli
from liaison_cli.campaign.study003 import CASES, case_scenario
from liaison_cli.scenario.schema import load_scenario

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
    proc = run_cli("study003", short, "--runs", "3", "--jobs", "1", "--output", out, "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "| cassini | DSN + LiAISON | Cassini |" in proc.stdout
    for name in ("summary.parquet", "histories.parquet", "table.md", "cassini_histories.png",
                 "departures_position_error.png"):
        assert (out / name).exists(), name
    summary = pd.read_parquet(out / "summary.parquet")
    departure = summary[summary.role == "departure"].set_index("case").sigma3d_rms_position_m
    assert departure["full"] < departure["dsn_only"] and departure["full"] < departure["liaison_only"]
    assert (summary.runs_ok == 3).all()
