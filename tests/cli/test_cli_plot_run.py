"""`liaison plot run RESULT_DIR` on a representative set of small results (an EKF CRTBP run, a batch run with
clock synchronisation, a dated run, a run with clock states, a run with a considered range bias): every
figure the result has data for is written as a non-empty PNG of the expected size and an SVG; a folder that
is not a run result is one line, exit 2."""

import struct
from pathlib import Path

import pytest
from typer.testing import CliRunner

from liaison_cli.cli import app

from tests.conftest import REPO, SCENARIOS
TEMPLATES = REPO / "liaison_cli" / "scenario" / "templates"
ALWAYS = {"errors", "nees", "innovations", "ric"}
CASES = {  # result: (scenario, runs, figures beyond ALWAYS); the EKF's consistency record draws its directions
    "ekf_crtbp": (SCENARIOS / "smoke.yaml", 2, {"directions"}),
    "batch": (TEMPLATES / "nrho-batch.yaml", 2, {"clocks"}),  # clock_sync's fitted clocks
    "dated": (TEMPLATES / "dated-dsn.yaml", 2, {"directions"}),
    "clock": (SCENARIOS / "clock_one_way_eml2_lunar.yaml", 2, {"clocks", "directions"}),
    "bias": (SCENARIOS / "bias_eml2_lunar.yaml", 2, {"bias", "directions"}),
}


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()[:24]
    assert data[:8] == b"\x89PNG\r\n\x1a\n", path
    return struct.unpack(">II", data[16:24])


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    root = tmp_path_factory.mktemp("results")
    for name, (scenario, runs, _) in CASES.items():
        ran = invoke("run", scenario, "--runs", runs, "--jobs", "1", "--quiet", "--output", root / name)
        assert ran.exit_code == 0, ran.output
    return root


@pytest.mark.parametrize("case", sorted(CASES))
def test_plot_run_draws_every_figure_the_result_has(results, case):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # a batch's missing sigma is no "Mean of empty slice"
        result = invoke("plot", "run", results / case)
    assert result.exit_code == 0, result.output
    plots = results / case / "plots"
    expected = ALWAYS | CASES[case][2]
    assert {p.stem for p in plots.glob("*.png")} == expected
    assert {p.stem for p in plots.glob("*.svg")} == expected
    for stem in expected:
        png, svg = plots / f"{stem}.png", plots / f"{stem}.svg"
        width, height = png_size(png)
        assert width == 1320 and 400 <= height <= 3000, (stem, width, height)  # 11 in wide at 120 dpi
        assert png.stat().st_size > 20_000 and svg.stat().st_size > 20_000
        assert svg.read_text().lstrip().startswith("<?xml") and "</svg>" in svg.read_text()[-100:]
        assert f"wrote {png}" in result.stdout
    assert not list(plots.glob(".*"))  # no temporary file left behind


def test_a_batch_result_says_what_a_batch_has(results):
    """issue 47's batch figures: the NEES of each run's solution by run against the single-run band (not a constant
    line scored per epoch), residual panels labelled post-fit residuals, and clock_sync's fitted clocks drawn from
    clocks.parquet, whose phase errors over the sync window give the summary's clock RMS."""
    import numpy as np

    from liaison_cli.report.run_plots import _draw_clocks, _draw_innovations, _draw_nees
    from liaison_cli.report.run_result import load_run_result

    result = load_run_result(results / "batch")
    nees = _draw_nees(result, 0)
    assert "NEES of each run's batch solution" in nees.axes[0].get_title() and nees.axes[0].get_xlabel() == "run"
    residuals = _draw_innovations(result, 0)
    assert {ax.get_ylabel() for ax in residuals.axes if ax.get_visible()} == {"post-fit residual / σ"}
    assert "clock_sync's fitted clocks" in _draw_clocks(result, 0)._suptitle.get_text()
    clocks, summary = result.clocks, result.summary
    for (run, clock), rows in clocks.dropna().groupby(["run", "clock"]):  # a 3 h window, then a 3 h prediction
        inside = rows[rows.t_s <= rows.t_s.max() - 3 * 3600.0 + 1e-6]
        rms_ns = float(np.sqrt(np.mean(inside.phase_error_ns.astype(float) ** 2)))
        stored = summary[(summary.run == run) & (summary.spacecraft == clock)].clock_rms_window_ns.iloc[0]
        assert rms_ns == pytest.approx(stored, rel=1e-5), (run, clock)
    assert clocks.clock.nunique() == 2 and len(clocks.dropna()) > 0


def test_plot_run_output_folder_and_highlighted_run(results, tmp_path):
    result = invoke("plot", "run", results / "ekf_crtbp", "--output", tmp_path / "figs", "--run", "1")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "figs" / "errors.png").exists()
    bad = invoke("plot", "run", results / "ekf_crtbp", "--run", "7")
    assert bad.exit_code == 2 and bad.stderr.strip().count("\n") == 0 and "--run 7" in bad.stderr


@pytest.mark.parametrize("what", ["empty folder", "missing folder", "a file"])
def test_a_folder_that_is_not_a_run_result_is_one_line(tmp_path, what):
    target = tmp_path / "target"
    if what == "empty folder":
        target.mkdir()
    elif what == "a file":
        target.write_text("x")
    result = invoke("plot", "run", target)
    assert result.exit_code == 2 and result.stdout == ""
    line = result.stderr.strip()
    assert "\n" not in line and str(target) in line and "liaison run" in line and "Traceback" not in line
    assert not (target / "plots").exists() if target.is_dir() else True


@pytest.mark.parametrize("table", ["summary", "timeseries", "consistency", "residuals"])
def test_a_result_whose_table_is_another_table_is_one_line(results, tmp_path, table):
    """Issue 47: a summary.parquet of some other kind was a traceback. Each required table without the columns
    the figures read first is one line naming the file, exit 4, and nothing is drawn."""
    import shutil

    import pandas as pd

    target = tmp_path / "result"
    shutil.copytree(results / sorted(CASES)[0], target, ignore=shutil.ignore_patterns("plots"))  # earlier tests drew
    pd.DataFrame({"a": [1, 2], "b": [3.0, 4.0]}).to_parquet(target / f"{table}.parquet")
    result = invoke("plot", "run", target)
    assert result.exit_code == 4 and result.stdout == "", result.output
    line = result.stderr.strip()
    assert "\n" not in line and f"{table}.parquet" in line and "not the table 'liaison run' writes" in line
    assert not (target / "plots").exists()


def test_the_ric_bars_are_the_run_texts_means(results):
    """Issue 47: ric.png's 'error RMS' bars were 2-5 % above the run text's numbers under the same label (the RMS
    over the runs against the mean over the runs). Both are now the mean over the healthy runs of each run's
    value: the first spacecraft's position bars equal the summary columns' means that format_ric prints."""
    import numpy as np

    from liaison_cli.analysis.ric import AXES
    from liaison_cli.report.consistency_plots import draw_ric
    from liaison_cli.report.run_result import load_run_result

    result = load_run_result(results / "ekf_crtbp")
    fig = draw_ric(result, 0)
    healthy = result.summary[result.summary.status == "ok"]
    first = healthy[healthy.spacecraft == healthy.spacecraft.iloc[0]]
    bars = [patch.get_height() for patch in fig.axes[0].patches]
    for stat, offset in (("rms", 0), ("sigma", 2 * len(AXES))):
        expected = [np.nanmean(first[f"{stat}_{axis}_position_settled_m"]) for axis in AXES]
        np.testing.assert_allclose(bars[offset : offset + len(AXES)], expected, rtol=1e-12)
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_time_axes_name_the_dated_epoch_and_the_settle_time_is_read(tmp_path):
    """Dated runs label their time axes with t0's TDB date (timeseries' epoch_tdb); every run's metadata carries
    the settle time the errors and NEES figures mark."""
    import pandas as pd

    from liaison_cli.report.run_plots import time_label
    from liaison_cli.report.run_result import RunResult, load_run_result
    from liaison_cli.scenario.loading import load_scenario
    from tests.conftest import SCENARIOS, run_cli_in_process

    empty = pd.DataFrame()
    dated = pd.DataFrame({"t_s": [0.0, 60.0], "epoch_tdb": pd.to_datetime(["2026-01-01 00:01:09.184",
                                                                             "2026-01-01 00:02:09.184"])})
    result = RunResult(tmp_path, "x", empty, dated, empty, empty, empty, empty)
    assert time_label(result) == "days from t0 = 2026-01-01 00:01:09 TDB"
    assert time_label(RunResult(tmp_path, "x", empty, dated[["t_s"]], empty, empty, empty, empty)) == \
        "time (days from t0)"
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--jobs", "1", "--quiet", "--output",
                              tmp_path / "r")
    assert proc.returncode == 0, proc.stderr
    assert load_run_result(tmp_path / "r").settle_days == load_scenario(SCENARIOS / "smoke.yaml")[0].settle_days()


@pytest.mark.parametrize("case", ["batch", "ekf_crtbp"])
def test_every_error_panel_is_on_a_log_axis(results, case):
    """issue 47: errors.png mixed linear and log panels (a batch's flat Anchor2 errors were linear)."""
    from liaison_cli.report.run_plots import _draw_errors
    from liaison_cli.report.run_result import load_run_result

    figure = _draw_errors(load_run_result(results / case), 0)
    assert {ax.get_yscale() for ax in figure.axes} == {"log"}
