"""002's tables (campaign.studies.tables002 computes them from a sweep) as Markdown: DRMS p90 (Table 3 layout),
clock RMS p90 (Table 4 layout), the two readings of 002's links side by side, consistency; and the DRMS and
clock histograms of one grid cell (PNG). Formats and draws only."""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT

# The `reading` of a scenario (campaign.studies.tables002) as the consistency table names it after the case.
READING_LABELS = {"mesh": " + anchor link", "visible": " always-visible station"}


def format_batch_consistency(table: pd.DataFrame) -> str:
    """The consistency table as Markdown, one row per grid cell, case and spacecraft ('+ anchor link' or
    'always-visible station' after the case for a second reading); '!' marks a ratio outside the ratio test's range, and a closing line
    counts the rows that fail the verdict."""
    def ratio(value):
        inside = 1.0 / CONSISTENCY_RATIO_LIMIT <= value <= CONSISTENCY_RATIO_LIMIT
        return "-" if value != value else f"{value:.2f}" + ("" if inside else " !")

    lines = ["Consistency after the settle time (filter.settle_days): error RMS and the batch's sigma RMS of the "
             "3-D position error over the runs that finished, error/σ of position and velocity (! outside "
             f"[{1 / CONSISTENCY_RATIO_LIMIT:.2f}, {CONSISTENCY_RATIO_LIMIT:g}]), share of epochs whose NEES lies in "
             "its 95 % band", "",
             "| span | interval | case | S/C | runs ok | position error RMS m | σ RMS m | pos err/σ | vel err/σ "
             "| NEES in band |", "|---|---|---|---|---|---|---|---|---|---|"]
    for row in table.itertuples():
        share = "-" if row.nees_in_band_share != row.nees_in_band_share else f"{100 * row.nees_in_band_share:.0f} %"
        case = f"{row.case} {row.measurements}" + READING_LABELS.get(getattr(row, "reading", None), "")
        lines.append(f"| {row.span_periods:.2g} T | {row.interval_s / 60:g} min | {case} | "
                     f"{row.spacecraft} | {row.runs_ok}/{row.runs} | {row.error_rms_position_m:.3f} | "
                     f"{row.sigma_rms_position_m:.3f} | {ratio(row.position_error_to_sigma)} | "
                     f"{ratio(row.velocity_error_to_sigma)} | {share} |")
    bad = int((~table.consistent).sum()) if len(table) else 0
    if bad:
        lines.append(f"\n! {bad} of {len(table)} rows fail the consistency verdict (analysis.consistency; "
                     "consistency.parquet: consistent, consistency_failed)")
    return "\n".join(lines) + "\n"


def format_tables(drms: pd.DataFrame, clocks: pd.DataFrame) -> str:
    """Both tables as Markdown."""
    columns = [("autonomous", "NORR"), ("autonomous", "RR"), ("earth", "NORR"), ("earth", "RR")]
    lines = ["DRMS p90 (m), mean over the constellation, 3 h prediction after the span (cf. 002 Table 3)", "",
             "| span | interval | autonomous NORR | autonomous RR | Earth NORR | Earth RR |",
             "|---|---|---|---|---|---|"]
    for row in drms.itertuples():
        cells = []
        for case, measurements in columns:
            value = getattr(row, f"{case}_{measurements}_drms_p90_m", np.nan)
            cells.append("" if value != value else f"{value:.3f}")
        lines.append(f"| {row.span_periods:.2g} T ({row.span_days:g} d) | {row.interval_min:g} min | "
                     + " | ".join(cells) + " |")
    lines += ["", "Clock RMS p90 (ns) of the anchors against the Gateway's clock, quadratic fit over the 3 h "
              "sync window (cf. 002 Table 4)", "",
              "| span | interval | measurements | over the window | over the 3 h prediction |", "|---|---|---|---|---|"]
    for row in clocks.itertuples():
        lines.append(f"| {row.span_periods:.2g} T | {row.interval_min:g} min | {row.measurements} | "
                     f"{row.clock_window_p90_ns:.2f} | {row.clock_prediction_p90_ns:.2f} |")
    return "\n".join(lines) + "\n"


def _cell(value, digits: int) -> str:
    return "-" if value != value else f"{value:.{digits}f}"


EARTH_READINGS_TEXT = (
    "Two readings of 002's Earth station (Earth-based case), DRMS p90 (m): shipped = one station at Canberra's "
    "latitude, 10 deg elevation mask, the Moon occulting; always visible = an idealised station that sees every "
    "spacecraft at every epoch (no horizon, no occultation), as a covariance analysis with a geocentric station "
    "assumes; ratio = always visible / shipped. 002 does not describe its station, and its Table 3 is withheld from "
    "our copy: no paper column.")
LINK_READINGS_TEXT = (
    "Two readings of 002's links (autonomous case), DRMS p90 (m): shipped = crosslinks Gateway <-> each anchor; "
    "+ anchor link = the anchors also range to each other; ratio = + anchor link / shipped. 002 Table 3's values are "
    "withheld from our copy of the paper: no paper column, no ratio to the paper.")


def _drms_readings(drms: pd.DataFrame, case: str, reading: str, label: str, text: str) -> list[str]:
    """One case's two readings side by side, per cell: the shipped reading's DRMS p90, the second reading's
    (`reading`, shown as `label`) and their ratio, with the runs that finished; [] when the tables lack it."""
    if not any(column == f"{case}_{m}_{reading}_ratio" for column in drms.columns for m in ("NORR", "RR")):
        return []
    lines = [text, "", f"| span | interval | NORR shipped | NORR {label} | NORR ratio | RR shipped | RR {label} "
             "| RR ratio |", "|---|---|---|---|---|---|---|---|"]
    for row in drms.itertuples():
        cells = []
        for measurements in ("NORR", "RR"):
            cells += [_cell(getattr(row, f"{case}_{measurements}_drms_p90_m", np.nan), 3),
                      _cell(getattr(row, f"{case}_{reading}_{measurements}_drms_p90_m", np.nan), 3),
                      _cell(getattr(row, f"{case}_{measurements}_{reading}_ratio", np.nan), 2)]
        lines.append(f"| {row.span_periods:.2g} T ({row.span_days:g} d) | {row.interval_min:g} min | "
                     + " | ".join(cells) + " |")
    columns = [f"{case}{second}_{m}" for second in ("", f"_{reading}") for m in ("NORR", "RR")]
    runs = [int(getattr(row, f"{c}_runs_ok")) for row in drms.itertuples() for c in columns if f"{c}_runs_ok" in drms]
    total = [int(getattr(row, f"{c}_runs")) for row in drms.itertuples() for c in columns if f"{c}_runs" in drms]
    if runs:
        finished = f"{min(runs)}" if min(runs) == max(runs) else f"{min(runs)}-{max(runs)}"
        lines += ["", f"Runs that finished, per cell and reading: {finished} of {max(total)}."]
    return lines


def format_readings(drms: pd.DataFrame, clocks: pd.DataFrame) -> str:
    """The second readings of 002 beside the shipped ones: the Earth station's (shipped, and idealised always
    visible) and the links' (autonomous case: Gateway <-> each anchor as shipped, and with the anchor <-> anchor
    link), per cell the two DRMS p90 and their ratio, and for the links the clocks too. '' when the tables hold
    neither second reading."""
    earth = _drms_readings(drms, "earth", "visible", "always visible", EARTH_READINGS_TEXT)
    links = _drms_readings(drms, "autonomous", "mesh", "+ anchor link", LINK_READINGS_TEXT)
    lines = earth + ([""] if earth and links else []) + links
    if not lines:
        return ""
    if "mesh_clock_window_p90_ns" in clocks:
        lines += ["", "Two readings, clock RMS p90 (ns) of the anchors against the Gateway's clock; in both readings "
                  "the fit uses the Gateway <-> anchor offsets only. 002 Table 4's values are withheld from our copy "
                  "of the paper: no paper column, no ratio to the paper.", "",
                  "| span | interval | measurements | window shipped | window + anchor link | window ratio "
                  "| prediction shipped | prediction + anchor link | prediction ratio |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for row in clocks.itertuples():
            lines.append(f"| {row.span_periods:.2g} T | {row.interval_min:g} min | {row.measurements} | "
                         f"{_cell(row.clock_window_p90_ns, 2)} | {_cell(row.mesh_clock_window_p90_ns, 2)} | "
                         f"{_cell(row.clock_window_mesh_ratio, 2)} | {_cell(row.clock_prediction_p90_ns, 2)} | "
                         f"{_cell(row.mesh_clock_prediction_p90_ns, 2)} | "
                         f"{_cell(row.clock_prediction_mesh_ratio, 2)} |")
    return "\n".join(lines) + "\n"


def draw_histograms(cell: pd.DataFrame, span_periods: float, interval_s: float, out_dir: Path) -> list[Path]:
    """DRMS histograms (cf. 002 Figs. 7-8) and clock RMS histograms (cf. Figs. 9-10) of one grid cell's runs
    (campaign.studies.tables002.histogram_cell)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex="col")
    for j, measurements in enumerate(("RR", "NORR")):
        for i, case in enumerate(("earth", "autonomous")):
            ax = axes[i, j]
            values = cell[(cell.case == case) & (cell.measurements == measurements)].drms_mean_m
            if len(values):
                ax.hist(values, bins=40, color="tab:blue" if case == "autonomous" else "tab:grey")
                _mark_p90(ax, values, "m")
            ax.set_title(f"{'Earth-based' if case == 'earth' else 'autonomous'} OD, {measurements} "
                         f"({len(values)} runs)", fontsize=10)
            ax.set_xlabel("DRMS of the 3 h prediction (m)")
    fig.suptitle(f"DRMS, span {span_periods:.2g} T, {interval_s / 60:g} min (cf. 002 Figs. 7-8)")
    fig.tight_layout()
    paths.append(_save(fig, out_dir / "drms_histograms.png"))
    plt.close(fig)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    own = cell[cell.case == "autonomous"]
    for ax, measurements in zip(axes, ("RR", "NORR")):
        mine = own[own.measurements == measurements]
        columns = [c for c in mine.columns if c.startswith("clock_window_")]
        values = mine[columns].to_numpy().ravel() if columns else np.array([])
        values = values[np.isfinite(values)]
        if values.size:
            ax.hist(values, bins=40, color="tab:green")
            _mark_p90(ax, values, "ns")
        ax.set_title(f"autonomous timing, {measurements} ({values.size} anchor-runs)", fontsize=10)
        ax.set_xlabel("clock RMS over the 3 h sync window (ns)")
    fig.suptitle("Clock synchronisation error (cf. 002 Figs. 9-10)")
    fig.tight_layout()
    paths.append(_save(fig, out_dir / "clock_histograms.png"))
    plt.close(fig)
    return paths


def _mark_p90(ax, values, unit: str) -> None:
    """The 90th percentile of the finite values as a dashed line, labelled."""
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)]
    p90 = float(np.quantile(finite, 0.9)) if finite.size else np.nan
    ax.axvline(p90, color="black", ls="--", lw=1, label=f"p90 {p90:.2f} {unit}")
    ax.legend(fontsize=8)


def _save(fig, path: Path) -> Path:
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    tmp.replace(path)
    return path
