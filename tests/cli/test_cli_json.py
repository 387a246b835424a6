"""`--json` on run, sweep, compare, budget, errors, validate, observability, design, tune and the study commands (table3,
geometry, study003, study004, tables002): standard output is one JSON object whose keys
are exactly those docs/json-output.md documents, its numbers are the ones the text prints, and errors stay
one line on standard error with the usual exit code (nothing on standard output)."""

import json
import re

import pytest
from typer.testing import CliRunner

from liaison_cli.cli import app

from tests.conftest import REPO, SCENARIOS
DOC = REPO / "docs" / "json-output.md"


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def documented_tables(command: str) -> list[set[str]]:
    """The first-column keys of each table in the doc's section for `liaison COMMAND --json`."""
    text = DOC.read_text()
    section = text.split(f"## `liaison {command} --json`")[1].split("\n## ")[0]
    tables, current = [], None
    for line in section.splitlines():
        if line.startswith("| ") and not line.startswith("| key") and not line.startswith("| ---"):
            current = set() if current is None else current
            current |= set(re.findall(r"`([a-z0-9_]+)`", line.split(" | ")[0]))
        elif current is not None:
            tables.append(current)
            current = None
    if current is not None:
        tables.append(current)
    return tables


def parsed(result) -> dict:
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "smoke"
    return invoke("run", SCENARIOS / "smoke.yaml", "--jobs", "1", "--quiet", "--output", out, "--json")


def test_run_json_has_the_documented_keys_and_the_printed_numbers(smoke_run, tmp_path):
    summary = parsed(smoke_run)
    top, per_spacecraft = documented_tables("run")
    assert set(summary) == top
    assert summary["command"] == "run" and summary["runs"] == summary["runs_ok"] == 2
    assert set(summary["spacecraft"]) == {"EML2", "Lunar"}
    for figures in summary["spacecraft"].values():
        assert set(figures) <= per_spacecraft
        assert 0.0 <= figures["frac_in_3sigma_after_day1"] <= 1.0
    # the same campaign as text prints the same position RMS (1 decimal) and no JSON
    text = invoke("run", SCENARIOS / "smoke.yaml", "--jobs", "1", "--quiet", "--output", tmp_path / "text")
    row = next(line for line in text.stdout.splitlines() if line.startswith("EML2 "))
    assert row.split()[1] == f"{summary['spacecraft']['EML2']['rms_position_m']:.1f}"
    assert "info:" not in smoke_run.stderr  # the stage times need -v


def test_verbose_shows_the_stage_times_on_stderr(tmp_path):
    result = invoke("-v", "run", SCENARIOS / "smoke.yaml", "--jobs", "1", "--quiet", "--output", tmp_path / "o",
                    "--json")
    json.loads(parsed(result) and result.stdout)  # stdout stays pure JSON under -v
    assert re.search(r"^info: smoke: truth, measurement plan and filter set up in [0-9.]+ s$", result.stderr,
                     re.MULTILINE), result.stderr
    assert re.search(r"^info: smoke: 2 runs estimated and written in [0-9.]+ s", result.stderr, re.MULTILINE)
    quiet = invoke("validate", SCENARIOS / "smoke.yaml")  # -v does not stay on for the next command
    assert quiet.exit_code == 0 and "info:" not in quiet.stderr


def test_compare_json(tmp_path):
    other = tmp_path / "pair.yaml"
    assert invoke("new", other, "--from", "crosslink-pair").exit_code == 0
    summary = parsed(invoke("compare", SCENARIOS / "smoke.yaml", other, "--runs", "1", "--jobs", "1", "--quiet",
                            "--output", tmp_path / "cmp", "--json"))
    (top,) = documented_tables("compare")
    assert set(summary) == top
    assert [row["scenario"] for row in summary["scenarios"]] == ["smoke", "pair"]
    assert all(row["runs_ok"] == 1 and row["rms_position_m"] > 0 for row in summary["scenarios"])


def test_sweep_json(tmp_path):
    summary = parsed(invoke("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100,200", "--runs", "1", "--jobs", "1",
                            "--quiet", "--output", tmp_path / "sw", "--json"))
    (top,) = documented_tables("sweep")
    assert set(summary) == top
    assert summary["grid_keys"] == ["noise.sigma_m"] and summary["points"] == 2 and summary["tasks"] == 2
    assert summary["computed"] + summary["reused"] == 2
    assert sorted({row["noise.sigma_m"] for row in summary["curve"]}) == [100, 200]
    assert {"point", "scenario", "spacecraft", "runs", "runs_ok", "runs_excluded"} <= set(summary["curve"][0])


def test_budget_json_matches_the_text():
    link = SCENARIOS / "links" / "turan2022_table2.yaml"
    summary = parsed(invoke("budget", link, "--json"))
    (top,) = documented_tables("budget")
    assert set(summary) == top
    text = invoke("budget", link).stdout
    printed = re.search(r"time-derived \(Eq. 4\)\s+([0-9.]+) m", text)
    assert printed, text
    assert f"{summary['ranging_sigma_m']['time_derived']:.1f}" == printed.group(1)
    assert summary["legs"]["uplink"]["distance_km"] > 0 and summary["expected_errors"] is None


def test_errors_json(tmp_path):
    scenario = tmp_path / "smoke_filter.yaml"
    scenario.write_text((SCENARIOS / "smoke.yaml").read_text() + "filter: {}\n")
    summary = parsed(invoke("errors", scenario, "--output", tmp_path / "eb", "--json"))
    (top,) = documented_tables("errors")
    assert set(summary) == top
    totals = [row for row in summary["shares"] if row["part"] == "total"]
    assert {row["spacecraft"] for row in totals} == {"EML2", "Lunar"}
    for name in ("EML2", "Lunar"):  # the parts' shares add up to the total
        parts = [row["position_share"] for row in summary["shares"]
                 if row["spacecraft"] == name and row["part"] != "total"]
        assert sum(parts) == pytest.approx(1.0, abs=1e-6)
    assert (tmp_path / "eb" / "budget.parquet").exists()


def test_validate_json_lists_every_file_and_still_fails(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text((SCENARIOS / "smoke.yaml").read_text().replace("sigma_m: 150", "sigma_m: -1"))
    result = invoke("validate", SCENARIOS / "smoke.yaml", bad, "--json")
    assert result.exit_code == 2
    summary = json.loads(result.stdout)
    (top,) = documented_tables("validate")
    assert set(summary) == top and summary["ok"] == 1 and summary["failed"] == 1
    assert [f["ok"] for f in summary["files"]] == [True, False]
    assert str(bad) in summary["files"][1]["error"]
    assert result.stderr.strip().count("\n") == 0 and str(bad) in result.stderr


def test_an_error_in_json_mode_is_one_line_and_no_json(tmp_path):
    result = invoke("run", tmp_path / "missing.yaml", "--json")
    assert result.exit_code == 2 and result.stdout == ""
    assert result.stderr.strip().count("\n") == 0 and "missing.yaml" in result.stderr


def test_observability_json_is_its_summary_file(tmp_path):
    summary = parsed(invoke("observability", SCENARIOS / "smoke.yaml", "--no-taylor", "--output", tmp_path / "o",
                            "--json"))
    (top,) = documented_tables("observability")
    assert set(summary) == top - {"taylor_stm"}  # --no-taylor
    written = json.loads((tmp_path / "o" / "observability.json").read_text())
    assert {key: summary[key] for key in written} == written


def test_design_json_lists_the_ranked_candidates(tmp_path):
    import pandas as pd
    import yaml

    from tests.cli.test_design import BASE

    base = tmp_path / "base.yaml"
    base.write_text(yaml.safe_dump(BASE, sort_keys=False))
    summary = parsed(invoke("design", base, "--open", "Relay", "--family", "dro", "--periods", "5:11:3", "--verify",
                            "0", "--jobs", "1", "--output", tmp_path / "d", "--json"))
    top, candidate = documented_tables("design")
    assert set(summary) == top and all(set(row) == candidate for row in summary["candidates"])
    table = pd.read_parquet(tmp_path / "d" / "candidates.parquet")
    assert [row["score_m"] for row in summary["candidates"]] == table.score_m.tolist()
    assert all(row["mc_score_m"] is None for row in summary["candidates"])  # --verify 0


def test_tune_json_rows_are_the_parquets(tmp_path):
    import pandas as pd

    summary = parsed(invoke("tune", SCENARIOS / "smoke.yaml", "--ladder", "1e-10,1e-9", "--runs", "4", "--jobs", "1",
                            "--work", tmp_path / "w", "--table", tmp_path / "t.md", "--quiet", "--json"))
    (top,) = documented_tables("tune")
    assert set(summary) == top
    table = pd.read_parquet(tmp_path / "t.parquet")
    assert len(summary["rows"]) == len(table) and [r["spacecraft"] for r in summary["rows"]] == list(table.spacecraft)
    assert [r["setting"] for r in summary["rows"]] == list(table.setting)


def _study_rows_are_the_parquets(summary, folder, command):
    """The documented top-level keys, and each table's rows equal to its Parquet's (same rows, same columns)."""
    import pandas as pd

    (top,) = documented_tables(command)
    assert set(summary) == top and summary["command"] == command and summary["output"] == str(folder)
    for stem, rows in summary["tables"].items():
        table = pd.read_parquet(folder / f"{stem}.parquet")
        assert len(rows) == len(table) and set(rows[0]) == set(table.columns), stem
    return summary


def test_geometry_json_rows_are_the_parquets(tmp_path):
    out = tmp_path / "geo"
    summary = _study_rows_are_the_parquets(parsed(invoke("geometry", "--count", "2", "--interval", "7200", "--output",
                                                         out, "--json")), out, "geometry")
    assert set(summary["tables"]) == {"l1_l2_halo", "l2_halo_lunar"} and summary["count"] == 2
    import pandas as pd

    table = pd.read_parquet(out / "l1_l2_halo.parquet")
    assert [row["range_condition_number"] for row in summary["tables"]["l1_l2_halo"]] == list(
        table.range_condition_number)


def test_study004_json_rows_are_the_parquets(tmp_path):
    from tests.studies.test_study004 import _one_day_halo

    out = tmp_path / "s4"
    summary = _study_rows_are_the_parquets(parsed(invoke("study004", _one_day_halo(tmp_path), "--runs", "1", "--jobs",
                                                         "1", "--quiet", "--output", out, "--json")), out, "study004")
    assert set(summary["tables"]) == {"summary", "claims"} and summary["runs"] == 1 and summary["grid_keys"] == []


def test_study003_json_rows_are_the_parquets(tmp_path):
    from tests.studies.test_study003 import CASSINI

    short = tmp_path / "cassini.yaml"
    short.write_text(CASSINI.read_text().replace("duration_days: 9", "duration_days: 1"))
    out = tmp_path / "s3"
    summary = _study_rows_are_the_parquets(parsed(invoke("study003", short, "--runs", "1", "--jobs", "1", "--quiet",
                                                         "--output", out, "--json")), out, "study003")
    assert set(summary["tables"]) == {"summary"} and summary["dsn_noise"] is None


def test_table3_json_rows_are_the_parquets(tmp_path):
    out = tmp_path / "t3"
    summary = _study_rows_are_the_parquets(parsed(invoke("table3", "--runs", "1", "--jobs", "1", "--quiet", "--output",
                                                         out, "--json")), out, "table3")
    assert summary["runs_per_case"] == 1 and set(summary["tables"]) == {"table3"}
    assert summary["ordering_checks"] and all(isinstance(v, bool) for v in summary["ordering_checks"].values())


def test_export_json_names_the_frame_and_files(smoke_run, tmp_path):
    result = json.loads(smoke_run.stdout)["output"]
    summary = parsed(invoke("export", result, "--format", "kvn", "--frame", "icrf", "--epoch", "2030-01-01T00:00:00",
                            "--output", tmp_path / "x", "--json"))
    (top,) = documented_tables("export")
    assert set(summary) == top
    assert (summary["ref_frame"], summary["center_name"], summary["time_system"]) == ("ICRF", "EARTH", "TDB")
    assert sorted(summary["files"]) == sorted(p.name for p in (tmp_path / "x").iterdir() if not p.name.startswith("."))
    refused = invoke("export", result, "--frame", "icrf", "--output", tmp_path / "y")
    assert refused.exit_code == 2 and "--epoch" in refused.stderr and not (tmp_path / "y").exists()


def test_orbits_list_and_show_json():
    from liaison_cli.orbits.families import FAMILIES

    listed = parsed(invoke("orbits", "list", "--json"))
    (top,) = documented_tables("orbits list")
    assert set(listed) == top and set(listed["families"]) == set(FAMILIES)
    shown = parsed(invoke("orbits", "show", "dro", "--json"))
    (top,) = documented_tables("orbits show")
    assert set(shown) == top and len(shown["members"]) == 30
    assert [row["member"] for row in shown["members"]] == list(range(len(shown["members"])))
