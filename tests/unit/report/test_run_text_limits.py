"""Issue 35 ("templates that look broken"): the run text names a limit a table of RMS and err/σ hides, only when it
applies. A batch whose normal equations are weak (report.run_text.weak_batch_line, printed under the prediction
table) and, from a result folder, a link that measures at a small share of the epochs (run_result.link_coverage,
run_text.coverage_lines)."""

import math

import numpy as np

from liaison_cli.report.run_text import (COVERAGE_FLAG, WEAK_BATCH_CONDITION, coverage_lines, format_prediction,
                                         link_coverage, weak_batch_line)


def _batch_rows(condition: float, status: str = "ok") -> list[dict]:
    return [{"run": run, "spacecraft": name, "status": status, "rms_position_prediction_m": 1.0,
             "batch_condition": condition} for run in range(2) for name in ("Gateway", "Anchor1")]


def test_a_weak_batch_is_named_under_its_prediction_table():
    # the nrho-batch template with a 3 d span (before issue 35): condition 1.9e9, errors 400-600 m
    text = format_prediction(_batch_rows(1.9e9), ["Gateway", "Anchor1"])
    assert text.splitlines()[-1].startswith("weak batch: the normal equations' condition number is 1.9e+09")
    assert "above 1e+07" in text


def test_a_well_conditioned_batch_prints_no_limit_line():
    # the template as written (1.5 NRHO periods): 1.3e5; the shipped 002 scenarios 1.9e4 to 1.4e5
    for condition in (1.3e5, 1.6e6, WEAK_BATCH_CONDITION):
        assert "weak batch" not in format_prediction(_batch_rows(condition), ["Gateway", "Anchor1"])


def test_the_weak_batch_line_reads_only_finished_runs_and_batch_results():
    assert weak_batch_line(_batch_rows(1.9e9, status="diverged")) == ""
    assert weak_batch_line(_batch_rows(math.nan)) == ""
    assert weak_batch_line([{"run": 0, "spacecraft": "EML2", "status": "ok", "rms_position_m": 1.0}]) == ""


def test_a_link_measuring_a_small_share_of_the_arc_is_named():
    epochs = 216  # 1.5 d at 600 s
    ground = np.zeros(epochs, dtype=bool)
    ground[60:120] = True  # one pass: 60 of 216 epochs, as the Mauna Kea / Owens Valley pair (28 %)
    # Two channels per link (TDoA and FDoA) as the scenario's data has them: available (m - 1, C).
    available = np.stack([ground, ground, ground | True, ground | True], axis=1)
    shares = link_coverage(available, ["MaunaKea/OwensValley->TX"] * 2 + ["GEO130W/GEO170W->TX"] * 2)
    assert shares == {"MaunaKea/OwensValley->TX": 60 / 216, "GEO130W/GEO170W->TX": 1.0}
    (line,) = coverage_lines(shares, 1.5)
    assert line.startswith("MaunaKea/OwensValley->TX measured at 28 % of the epochs (about 0.42 of 1.5 d)")


def test_full_coverage_prints_no_line():
    epochs = 216
    space = np.ones(epochs, dtype=bool)
    space[:15] = False  # occulted at 7 % of the epochs, as the GEO pair: above COVERAGE_FLAG
    fdoa_only = space.copy()
    fdoa_only[:30] = False  # a link counts an epoch when any of its channels has data
    shares = link_coverage(np.stack([space, fdoa_only], axis=1), ["GEO130W/GEO170W->TX"] * 2)
    assert shares == {"GEO130W/GEO170W->TX": (epochs - 15) / epochs}
    assert shares["GEO130W/GEO170W->TX"] > COVERAGE_FLAG and coverage_lines(shares, 1.5) == []
    assert link_coverage(np.zeros((0, 2), dtype=bool), ["a", "b"]) == {}
    assert coverage_lines({"ground": 0.5}, 240.0)[0].startswith("ground measured at 50 % of the epochs (about 120 of 240 d)")
