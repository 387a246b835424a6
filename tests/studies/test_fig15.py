"""Fig. 15: the default sigma sweep against the paper, the plot, and the link-budget read-off."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.campaign.studies.table3 import paper_table3, tolerances
from tests.conftest import SCENARIOS, run_cli_in_process

HALO_LUNAR = ("eml2_lunar", "eml1_lunar")


@pytest.fixture(scope="module")
def default_sweep(tmp_path_factory):
    """`liaison sweep` of the paper's three formations at its Table 3 sigmas and the ends of Fig. 15's range (3
    formations x 4 sigma x 10 runs; the whole figure's 14 sigma: test_the_whole_figure_sweep_as_a_user_types_it)."""
    out = tmp_path_factory.mktemp("fig15") / "sweep"
    proc = run_cli_in_process("sweep", "--sigma", "50,150,300,700", "--quiet", "--output", out)
    assert proc.returncode == 0, proc.stderr
    assert "12 grid points x 10 runs = 120 tasks: 120 computed" in proc.stdout
    return out


@pytest.mark.slow
def test_the_whole_figure_sweep_as_a_user_types_it(tmp_path):
    """`liaison sweep --sigma 50:700` exactly as the README's figure was made (3 formations x 14 sigma x 10 runs):
    the default grid, and every spacecraft's error at 700 m above its error at 50 m."""
    proc = run_cli_in_process("sweep", "--sigma", "50:700", "--quiet", "--output", tmp_path / "sweep")
    assert proc.returncode == 0, proc.stderr
    assert "42 grid points x 10 runs = 420 tasks: 420 computed" in proc.stdout
    curve = pd.read_parquet(tmp_path / "sweep" / "curve.parquet")
    for _, rows in curve.groupby(["scenario", "spacecraft"]):
        mean = rows.sort_values("sigma_m").rms_position_m_mean.to_numpy()
        assert len(mean) == 14 and mean[-1] > mean[0]


def _paired_z(runs: pd.DataFrame, metric: str) -> pd.Series:
    """Mean change between neighbouring sigma values over its standard error, paired by run (the grid
    points share random numbers). Large negative = error significantly falls as sigma grows."""
    z = {}
    for (scenario, spacecraft), rows in runs.groupby(["scenario", "spacecraft"]):
        table = rows.pivot(index="run", columns="sigma_m", values=metric)
        steps = table.diff(axis=1).iloc[:, 1:]
        z[(scenario, spacecraft)] = (steps.mean() / (steps.std(ddof=1) / np.sqrt(len(steps)))).min()
    return pd.Series(z)


def test_position_curves_monotone_within_monte_carlo_noise(default_sweep):
    runs = pd.read_parquet(default_sweep / "runs.parquet")
    assert set(runs.status) == {"ok"}
    for metric in ("rms_position_m", "rms_position_after_day1_m"):
        z = _paired_z(runs[runs.scenario.isin(HALO_LUNAR)], metric)
        assert (z > -2.0).all(), z  # no step down larger than 2 standard errors
    curve = pd.read_parquet(default_sweep / "curve.parquet")
    for (scenario, _), rows in curve.groupby(["scenario", "spacecraft"]):
        mean = rows.sort_values("sigma_m").rms_position_m_mean.to_numpy()
        assert mean[-1] > mean[0], scenario  # 700 m is worse than 50 m for every spacecraft


def test_paper_table3_points_within_factor_two_of_our_curves(default_sweep):
    curve = pd.read_parquet(default_sweep / "curve.parquet")
    paper = paper_table3()
    limits = {(e["formation"], e["spacecraft"], float(e["sigma_m"]), e["ratio"]): e["max_ratio"]
              for e in tolerances()["exceptions"]}
    checked = 0
    for ref in paper.itertuples():
        rows = curve[(curve.scenario == ref.formation) & (curve.spacecraft == ref.spacecraft)]
        rows = rows[rows.sigma_m == ref.sigma_m]
        assert len(rows) == 1
        position_ratio = rows.rms_position_m_mean.iloc[0] / ref.position_rms_m
        velocity_ratio = rows.rms_velocity_m_s_mean.iloc[0] / ref.velocity_rms_m_s
        assert 0.5 <= position_ratio <= 2.0, (ref, position_ratio)
        # One documented exception (see report/data/table3_tolerances.yaml): the EML2-lunar 150 m lunar
        # velocity, whose perilune-start transient our runs show more strongly than the paper's.
        key = (ref.formation, ref.spacecraft, float(ref.sigma_m), "velocity_ratio")
        limit = limits.get(key, 2.0)
        assert 0.5 <= velocity_ratio <= limit, (key, velocity_ratio)
        checked += 1
    assert checked == 12


def test_matched_models_give_strictly_rising_curves(tmp_path):
    """Without the light-time truth (filter model = truth model) there is no modelling-error floor, so
    every spacecraft's error rises with sigma from the smallest sigma on."""
    proc = run_cli_in_process("sweep", SCENARIOS / "eml2_lunar.yaml", SCENARIOS / "eml1_lunar.yaml", "--sigma", "50,150,450",
                   "--grid", "measurement.light_time=false", "--quiet", "--output", tmp_path / "m")
    assert proc.returncode == 0, proc.stderr
    runs = pd.read_parquet(tmp_path / "m" / "runs.parquet")
    assert (_paired_z(runs, "rms_position_m") > 2.0).all()


def test_plot_fig15_writes_png_and_svg(default_sweep, tmp_path):
    proc = run_cli_in_process("plot", "fig15", default_sweep, "--output", tmp_path / "fig")
    assert proc.returncode == 0, proc.stderr
    png, svg = tmp_path / "fig.png", tmp_path / "fig.svg"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 50_000
    text = svg.read_text()
    for label in ("Position error RMS [m]", "Velocity error RMS [mm/s]", "Crosslink ranging error",
                  "Turan et al. 2022, Table 3", "EML2 halo – lunar: Lunar"):
        assert label in text or label.replace(" ", "") in text.replace(" ", ""), label
    assert "eml2_lunar Lunar    150 m  position" in proc.stdout


def test_plot_needs_a_sigma_sweep(tmp_path):
    out = tmp_path / "interval"
    proc = run_cli_in_process("sweep", SCENARIOS / "smoke.yaml", "--grid", "measurement.interval_s=187.5,375",
                   "--runs", "1", "--quiet", "--output", out)
    assert proc.returncode == 0, proc.stderr
    proc = run_cli_in_process("plot", "fig15", out)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "Fig. 15 needs a --sigma sweep" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_budget_reads_the_papers_sigma_and_the_expected_error(default_sweep):
    proc = run_cli_in_process("budget", SCENARIOS / "links" / "turan2022_table2.yaml", "--sweep", default_sweep)
    assert proc.returncode == 0, proc.stderr
    assert "time-derived (Eq. 4)       171.8 m" in proc.stdout
    assert "needs ranging_clock_hz" in proc.stdout
    curve = pd.read_parquet(default_sweep / "curve.parquet")
    rows = curve[(curve.scenario == "eml2_lunar") & (curve.spacecraft == "Lunar")].sort_values("sigma_m")
    expected = np.interp(171.8, rows.sigma_m, rows.rms_position_m_mean)
    line = next(li for li in proc.stdout.splitlines() if "eml2_lunar" in li and "Lunar" in li)
    assert abs(float(line.split()[4]) - expected) < 1.0
    # The PN / telemetry sigmas of the assumed clock fall below the swept range: said, not extrapolated.
    proc = run_cli_in_process("budget", SCENARIOS / "links" / "table2_with_ranging_clock.yaml", "--sweep", default_sweep)
    assert proc.returncode == 0 and "outside swept 50-700 m" in proc.stdout


def test_budget_bad_link_file_is_one_line(tmp_path):
    text = (SCENARIOS / "links" / "turan2022_table2.yaml").read_text().replace("  downlink:", "  downlnk:")
    path = tmp_path / "link.yaml"
    path.write_text(text)
    proc = run_cli_in_process("budget", path)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert "\n" not in line and str(path) in line and "'downlnk'" in line and "downlink" in line
