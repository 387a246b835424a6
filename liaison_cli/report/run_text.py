"""The text `liaison run` prints: per-spacecraft tables of a campaign's summary rows (RMS, containment,
consistency after the settle time, smoothed figures, batch prediction, residual-gate rejections, run status)
and the fixed-width cell helpers the CLI's other tables use. Formats only: every number comes from the
summary rows (campaign.results) or analysis.metrics."""

import math


def right(text: str, width: int) -> str:
    """Right-aligned in `width`; a wider value keeps one space before it, so columns never run together."""
    return text.rjust(width) if len(text) < width else " " + text


def left(text: str, width: int) -> str:
    return text.ljust(width) if len(text) < width else text + " "


def ok_values(summary: list[dict], spacecraft: str, column: str, scale: float = 1.0) -> list[float]:
    """The column's finite values over the runs that finished 'ok', for one spacecraft (NaN and absent
    entries left out, as a DataFrame's mean leaves them out)."""
    out = []
    for row in summary:
        value = row.get(column)
        if row.get("status") == "ok" and row.get("spacecraft") == spacecraft and value is not None \
                and math.isfinite(value):
            out.append(scale * value)
    return out


def mean(values: list[float]) -> float:
    return sum(values) / len(values) if values else math.nan


def quantile(values: list[float], q: float) -> float:
    """Linear interpolation between order statistics (numpy's and pandas' default)."""
    ordered = sorted(values)
    position = q * (len(ordered) - 1)
    low = math.floor(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (position - low) * (ordered[high] - ordered[low])


def format_summary(summary: list[dict], spacecraft) -> str:
    """Per spacecraft, the means over the runs that finished 'ok' of the summary rows' RMS and containment."""
    lines = [
        f"{'spacecraft':<12}{'pos RMS m':>11}{'[>1 d]':>9}{'vel RMS mm/s':>14}{'[>1 d]':>9}"
        f"{'in 2σ >1 d':>12}{'in 3σ >1 d':>12}"
    ]
    for name in spacecraft:
        def column_mean(column, scale=1.0):
            return mean(ok_values(summary, name, column, scale))

        lines.append(
            left(name, 12) + right(f"{column_mean('rms_position_m'):.1f}", 11)
            + right(f"{column_mean('rms_position_after_day1_m'):.1f}", 9)
            + right(f"{column_mean('rms_velocity_m_s', 1e3):.3f}", 14)
            + right(f"{column_mean('rms_velocity_after_day1_m_s', 1e3):.3f}", 9)
            + right(f"{column_mean('frac_in_2sigma_after_day1', 100):.1f}", 11) + "%"
            + right(f"{column_mean('frac_in_3sigma_after_day1', 100):.1f}", 11) + "%"
        )
    return "\n".join(lines)


def campaign_ratio(summary: list[dict], spacecraft: str, kind: str, unit: str) -> float:
    """Error RMS over the runs' settled epochs divided by the sigma RMS over the same epochs (runs 'ok')."""
    from liaison_cli.analysis.metrics import campaign_error_to_sigma

    return campaign_error_to_sigma(ok_values(summary, spacecraft, f"rms_{kind}_settled_{unit}"),
                                   ok_values(summary, spacecraft, f"sigma_{kind}_settled_{unit}"))


def format_consistency(summary: list[dict], spacecraft, settle_days: float) -> str:
    """Per spacecraft after the settle time: error RMS / sigma RMS of position and velocity over the runs that
    finished, the mean share of epochs with the NEES in its 95 % band; '!' marks a ratio above the limit."""
    from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT

    lines = [f"consistency after {settle_days:g} d (error RMS / filter sigma RMS over the runs; NEES in its 95 % "
             "band, above it):", f"{'spacecraft':<12}{'pos err/σ':>11}{'vel err/σ':>12}{'NEES in band':>15}"
             f"{'above':>9}"]
    flagged = False
    for name in spacecraft:
        cells = []
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            ratio = campaign_ratio(summary, name, kind, unit)
            mark = " !" if ratio > CONSISTENCY_RATIO_LIMIT else "  "
            flagged |= ratio > CONSISTENCY_RATIO_LIMIT
            cells.append(f"{ratio:.2f}{mark}")
        band = mean(ok_values(summary, name, "frac_nees_in_band_settled", 100.0))
        above = mean(ok_values(summary, name, "frac_nees_above_band_settled", 100.0))
        lines.append(left(name, 12) + right(cells[0], 11) + right(cells[1], 12) + right(f"{band:.1f}", 14) + "%"
                     + right(f"{above:.1f}", 8) + "%")
    if flagged:
        lines.append(f"! inconsistent: error RMS above {CONSISTENCY_RATIO_LIMIT:g}x the filter's sigma RMS "
                     "(summary.parquet: consistent_settled)")
    return "\n".join(lines)


def format_smoothed(summary: list[dict], spacecraft) -> str:
    """With filter.smoother: rts, per spacecraft the smoothed error RMS (mean over runs) and its error / sigma
    ratio (campaign ratio) over all epochs after t0; empty without the smoother."""
    from liaison_cli.analysis.metrics import campaign_error_to_sigma

    if not any("rms_position_smoothed_m" in row for row in summary):
        return ""
    lines = ["RTS-smoothed, all epochs after t0:",
             f"{'spacecraft':<12}{'pos RMS m':>11}{'err/σ':>8}{'vel RMS mm/s':>14}{'err/σ':>8}"]
    for name in spacecraft:
        cells = []
        for kind, unit, scale, digits in (("position", "m", 1.0, 1), ("velocity", "m_s", 1e3, 3)):
            cells.append(right(f"{mean(ok_values(summary, name, f'rms_{kind}_smoothed_{unit}', scale)):.{digits}f}",
                                11 if kind == "position" else 14))
            ratio = campaign_error_to_sigma(ok_values(summary, name, f"rms_{kind}_smoothed_{unit}"),
                                            ok_values(summary, name, f"sigma_{kind}_smoothed_{unit}"))
            cells.append(right(f"{ratio:.2f}", 8))
        lines.append(left(name, 12) + "".join(cells))
    return "\n".join(lines)


def format_prediction(summary: list[dict], spacecraft) -> str:
    """For a batch scenario: the DRMS of the prediction after the span and the clock synchronisation RMS,
    mean [90th percentile] over the runs that finished; empty for an EKF scenario."""
    if not any("rms_position_prediction_m" in row for row in summary):
        return ""
    clocks = any("clock_rms_window_ns" in row for row in summary)
    lines = [f"{'spacecraft':<12}{'prediction RMS m':>22}" + (f"{'clock RMS ns, window':>26}"
                                                               f"{'3 h prediction':>22}" if clocks else "")]
    for name in spacecraft:
        def stat(column):
            values = ok_values(summary, name, column)
            return f"{mean(values):.2f} [{quantile(values, 0.9):.2f}]" if values else "-"

        line = left(name, 12) + right(stat("rms_position_prediction_m"), 22)
        if clocks:
            line += right(stat("clock_rms_window_ns"), 26) + right(stat("clock_rms_prediction_ns"), 22)
        lines.append(line)
    return "after the data span, mean [90th percentile] over runs:\n" + "\n".join(lines)


def rejection_line(summary: list[dict], spec) -> str:
    """With the residual gate on (`spec`: the scenario's filter section): the measurements it rejected over
    all runs (ok or diverged) and the mean share per run; empty without a gate."""
    if spec.residual_gate_sigma is None:
        return ""
    first_rows: dict = {}
    for row in summary:
        if "rejected_measurements" in row:
            first_rows.setdefault(row["run"], row)
    counts = [row["rejected_measurements"] for row in first_rows.values()]
    shares = [row["rejected_share"] for row in first_rows.values() if math.isfinite(row["rejected_share"])]
    return (f"residual gate {spec.residual_gate_sigma:g} sigma after {spec.residual_gate_after} accepted: "
            f"{sum(counts)} measurements rejected in {len(counts)} runs ({100.0 * mean(shares):.3g} % per run); "
            "per link: residuals.parquet, column rejected")


def status_line(summary: list[dict]) -> str:
    first_rows: dict = {}
    for row in summary:
        first_rows.setdefault(row["run"], row)
    runs = list(first_rows.values())
    bad = [row for row in runs if row["status"] != "ok"]
    text = f"{len(runs) - len(bad)}/{len(runs)} runs ok"
    if bad:
        reasons = "; ".join(f"run {r['run']}: {r['status']} ({r['reason']})" for r in bad)
        text += f"; excluded from the averages: {reasons}"
    return text
