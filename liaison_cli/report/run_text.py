"""The text `liaison run` prints: per-spacecraft tables of a campaign's summary rows (RMS, containment,
consistency after the settle time, smoothed figures, batch prediction, residual-gate rejections, run status)
and the fixed-width cell helpers the CLI's other tables use. Formats only: every number comes from the
summary rows (campaign.engine.results) or analysis.metrics."""

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

        if not ok_values(summary, name, "rms_position_m"):
            lines.append(left(name, 12) + "  - (no run finished healthy: see the status line)")
            continue

        lines.append(
            left(name, 12) + right(_shown(column_mean('rms_position_m'), ".1f"), 11)
            + right(_shown(column_mean('rms_position_after_day1_m'), ".1f"), 9)
            + right(_shown(column_mean('rms_velocity_m_s', 1e3), ".3f"), 14)
            + right(_shown(column_mean('rms_velocity_after_day1_m_s', 1e3), ".3f"), 9)
            + right(_shown(column_mean('frac_in_2sigma_after_day1', 100), ".1f", "%"), 12)
            + right(_shown(column_mean('frac_in_3sigma_after_day1', 100), ".1f", "%"), 12)
        )
    return "\n".join(lines)


def _shown(value: float, spec: str, unit: str = "") -> str:
    """value formatted with its unit; '-' when there is none (no epoch after day 1 in a scenario of a day or
    less), never 'nan'."""
    return f"{value:{spec}}{unit}" if math.isfinite(value) else "-"


def campaign_ratio(summary: list[dict], spacecraft: str, kind: str, unit: str) -> float:
    """Error RMS over the runs' settled epochs divided by the sigma RMS over the same epochs (runs 'ok')."""
    from liaison_cli.analysis.metrics import campaign_error_to_sigma

    return campaign_error_to_sigma(ok_values(summary, spacecraft, f"rms_{kind}_settled_{unit}"),
                                   ok_values(summary, spacecraft, f"sigma_{kind}_settled_{unit}"))


CONSISTENCY_COLUMNS = ("rms_position_settled_m", "sigma_position_settled_m", "rms_velocity_settled_m_s",
                       "sigma_velocity_settled_m_s", "frac_nees_in_band_settled", "frac_nees_above_band_settled",
                       "frac_nees_spacecraft_in_band_settled", "frac_nees_spacecraft_above_band_settled")
DIRECTION_FLAG = 2.0  # a direction whose mean NEES component is above this (1 expected) is named


def format_consistency(summary: list[dict], spacecraft, settle_days: float) -> str:
    """Per spacecraft after the settle time, over the runs that finished: the campaign error / sigma ratios with
    their 95 % intervals, the NEES test's shares (whole state and the spacecraft's own 6 states) and the
    verdict (analysis.consistency.campaign_verdict); then the NEES by direction (format_directions)."""
    from liaison_cli.analysis.consistency import NEES_REQUIRED_SHARE, campaign_verdict

    lines = [f"consistency after {settle_days:g} d (error RMS / sigma RMS over the runs, 95 % interval; NEES test: "
             f"share of epochs in the single-run 95 % chi-square band, {100 * NEES_REQUIRED_SHARE:.0f} % needed, whole state "
             "and own 6 states):",
             f"{'spacecraft':<12}{'pos err/σ':>13}{'vel err/σ':>13}{'NEES state':>12}{'above':>7}{'own':>7}"
             f"{'consistent':>12}"]
    failures = []
    for name in spacecraft:
        if not ok_values(summary, name, "rms_position_settled_m"):
            lines.append(left(name, 12) + "  - (no healthy run, or no epoch after the settle time)")
            continue
        out = campaign_verdict({column: ok_values(summary, name, column) for column in CONSISTENCY_COLUMNS})
        cells = [_ratio_cell(out[f"{kind}_error_to_sigma_settled"], out[f"{kind}_error_to_sigma_halfwidth"])
                 for kind in ("position", "velocity")]
        lines.append(left(name, 12) + right(cells[0], 13) + right(cells[1], 13)
                     + right(_percent(out["frac_nees_in_band_settled"]), 12)
                     + right(_percent(out["frac_nees_above_band_settled"]), 7)
                     + right(_percent(out["frac_nees_spacecraft_in_band_settled"]), 7)
                     + right("yes" if out["consistent_settled"] else "no", 12))
        if not out["consistent_settled"]:
            failures.append(f"{name}: {out['consistency_failed']}")
    lines += format_directions(summary, spacecraft)
    lines += [f"not consistent: {failure}" for failure in failures]
    return "\n".join(lines)


def format_advice(advice) -> str:
    """One `advice:` line per campaign.advice.Advice (what to change, and the scenario key); '' when none."""
    return "\n".join(f"advice: {item.text}" for item in advice)


def _ratio_cell(ratio: float, half_width: float) -> str:
    return f"{ratio:.2f}±{half_width:.2f}" if math.isfinite(half_width) else f"{ratio:.2f}"


def _percent(share: float) -> str:
    return f"{100.0 * share:.0f} %" if math.isfinite(share) else "-"


def format_directions(summary: list[dict], spacecraft) -> list[str]:
    """The whole-state NEES's mean components along the common time shift and along the linked pair's line of
    sight whose component is largest (1 each when consistent), with the mean error there in sigma; the
    largest is named when above DIRECTION_FLAG. Empty when the estimator does not resolve directions."""
    name = spacecraft[0]  # run-level columns: the same in every spacecraft row
    total = mean(ok_values(summary, name, "mean_nees_settled"))
    shift = mean(ok_values(summary, name, "time_shift_nees_settled"))
    if not math.isfinite(shift):
        return []
    lines = [f"NEES by direction (mean over the runs of its component; 1 expected; whole state {total:.1f}):"]
    shift_bias = mean(ok_values(summary, name, "time_shift_bias_sigma_settled"))
    lag = mean(ok_values(summary, name, "time_shift_lag_s_settled"))
    found = [(shift, "common time shift", f"{shift:.1f}, error {shift_bias:+.1f} σ: the estimate "
              f"{'lags' if lag >= 0 else 'leads'} the truth by {abs(lag):.4g} s")]
    pairs = {row.get("along_link_pair") for row in summary if row.get("status") == "ok" and row.get("along_link_pair")}
    for pair in sorted(pairs):
        chosen = [row for row in summary if row.get("status") == "ok" and row.get("spacecraft") == name
                  and row.get("along_link_pair") == pair]
        value = mean([row["along_link_nees_settled"] for row in chosen])
        bias = mean([row["along_link_bias_sigma_settled"] for row in chosen])
        found.append((value, f"along {pair}", f"{value:.1f}, error {bias:+.1f} σ (the pair's line of sight; "
                      f"largest of the pairs in {len(chosen)} run(s))"))
    for _, label, text in found:
        lines.append(f"  {label}: {text}")
    worst = max(found)
    if worst[0] > DIRECTION_FLAG:
        lines.append(f"  most overconfident named direction: {worst[1]} ({worst[0]:.1f} of the NEES of {total:.1f})")
    return lines


def format_ric(summary: list[dict], spacecraft, settle_days: float) -> str:
    """Per spacecraft after the settle time, along its radial / in-track / cross-track axes (analysis.ric):
    error RMS, mean error and sigma RMS of position (m) and velocity (mm/s), means over the runs that
    finished; empty when the estimator records no covariance blocks."""
    from liaison_cli.analysis.ric import AXES

    if not any(math.isfinite(row.get("sigma_radial_position_settled_m", math.nan)) for row in summary):
        return ""
    lines = [f"RIC after {settle_days:g} d (about the nearer primary): error RMS / mean error / σ RMS",
             f"{'spacecraft':<12}{'':<5}" + "".join(f"{axis:>24}" for axis in ("radial", "in-track", "cross-track"))]
    for name in spacecraft:
        for kind, unit, scale, label in (("position", "m", 1.0, "m"), ("velocity", "m_s", 1e3, "mm/s")):
            cells = []
            for axis in AXES:
                values = [mean(ok_values(summary, name, f"{stat}_{axis}_{kind}_settled_{unit}", scale))
                          for stat in ("rms", "mean", "sigma")]
                digits = _position_digits(values) if kind == "position" else 2
                cells.append(right(f"{values[0]:.{digits}f} / {values[1]:+.{digits}f} / {values[2]:.{digits}f}", 24))
            lines.append(left(name if kind == "position" else "", 12) + left(label, 5) + "".join(cells))
    return "\n".join(lines)


def _position_digits(values) -> int:
    """Decimals for a RIC position cell (m): none from 10 m up, so a sub-metre axis (a radial error of 0.3 m)
    does not print as 0."""
    largest = max((abs(v) for v in values if math.isfinite(v)), default=0.0)
    return 0 if largest >= 10.0 else 1 if largest >= 1.0 else 2


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


# A batch solve whose equilibrated normal-equation condition number (summary column batch_condition, the same in
# every row of a run) is above this leaves some combination of the states almost undetermined by its span's data
# (sqrt(1e7) ~ 3,000: that combination's σ is ~3,000 times what the diagonal of the information alone implies),
# and the errors and σ the run prints follow it. Measured on the nrho-batch template (3 runs, position RMS):
# span 1.5 T (9.885 d) 1.3e5, ~1 m; 1 T 1.6e6, 3-5 m; 5 d 1.5e7, 15-18 m; 4 d 1.3e8, 130-170 m; 3 d 1.9e9,
# 400-600 m; 2 d refused (estimation.gauss_newton.CONDITION_LIMIT, 1e12). The shipped 002 scenarios (1 to 2 periods)
# lie at 1.9e4 to 1.4e5, two decades below the line, so they print nothing more.
WEAK_BATCH_CONDITION = 1e7


def format_prediction(summary: list[dict], spacecraft) -> str:
    """For a batch scenario: the DRMS of the prediction after the span and the clock synchronisation RMS,
    mean [90th percentile] over the runs that finished, and weak_batch_line when the solve was weak; empty for an
    EKF scenario."""
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
    weak = weak_batch_line(summary)
    return "after the data span, mean [90th percentile] over runs:\n" + "\n".join(lines + ([weak] if weak else []))


def weak_batch_line(summary: list[dict]) -> str:
    """When the largest batch condition number over the runs that finished is above WEAK_BATCH_CONDITION: one
    line saying so and what it means for the figures above (a user sees only consistent, large errors); else
    empty (an EKF run has no batch_condition)."""
    values = [row["batch_condition"] for row in summary if row.get("status") == "ok"
              and isinstance(row.get("batch_condition"), float) and math.isfinite(row["batch_condition"])]
    if not values or max(values) <= WEAK_BATCH_CONDITION:
        return ""
    return (f"weak batch: the normal equations' condition number is {max(values):.2g} (equilibrated; above "
            f"{WEAK_BATCH_CONDITION:.0e}): the span's data leave a combination of the states almost undetermined, "
            "and the errors and σ above follow it; a longer span (more of the orbit's geometry) or more "
            "observables lower it")


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


def link_coverage(available, links) -> dict[str, float]:
    """Per link, the share of the epochs after t0 at which it has a measurement: available (m - 1, C) bool, the
    channels' data after t0 (the scenario's, the same in every run: a run that diverged or a measurement the
    residual gate refused does not change it), links (C,) each channel's link label; a link counts an epoch
    when any of its channels has data. What run_text.coverage_lines reads."""
    import numpy as np

    available = np.asarray(available, dtype=bool)
    if available.size == 0:
        return {}
    out = {}
    for link in dict.fromkeys(links):
        columns = [c for c, name in enumerate(links) if name == link]
        out[str(link)] = float(np.mean(np.any(available[:, columns], axis=1)))
    return out


# A link measuring at fewer than this share of the epochs leaves much of the arc to its gaps (where a spacecraft
# no other link reaches rests on its dynamics and a priori), which a table of RMS and err/σ does not show.
# Measured: the templates' crosslinks 100 %, their GEO TDoA pair 89-93 % (both paths must clear the Earth and
# the Moon); ground passes about a third (dated-dsn's Goldstone 35 %, the Mauna Kea / Owens Valley TDoA pair
# 28 % of 1.5 d).
COVERAGE_FLAG = 0.8


def coverage_lines(shares: dict, duration_days: float) -> list[str]:
    """One line per link whose share of epochs with a measurement (report.run_result.link_coverage) is below
    COVERAGE_FLAG, saying how much of the arc it covered; none when every link covers the arc."""
    return [f"{link} measured at {100.0 * share:.0f} % of the epochs (about {_days(share * duration_days)} of "
            f"{duration_days:g} d): the figures above include its gaps, where it adds nothing"
            for link, share in sorted(shares.items()) if share < COVERAGE_FLAG]


def _days(days: float) -> str:
    """Two significant figures, never in exponent form (0.42, 3.5, 120)."""
    return f"{days:.2g}" if days < 10 else f"{days:.0f}"


def status_line(summary: list[dict]) -> str:
    first_rows: dict = {}
    for row in summary:
        first_rows.setdefault(row["run"], row)
    runs = list(first_rows.values())
    bad = [row for row in runs if row["status"] != "ok"]
    text = f"{len(runs) - len(bad)}/{len(runs)} runs ok"
    if bad:
        text += f"; excluded from the averages: {'; '.join(_failure(r) for r in bad)}"
    return text


def _failure(row: dict) -> str:
    """'run 3: diverged: NEES above ... at day 2.41' (the reason names the status; the epoch from fail_time_s)."""
    reason = row.get("reason") or row["status"]
    if not reason.startswith(row["status"]):
        reason = f"{row['status']}: {reason}"
    when, size = row.get("fail_time_s"), row.get("fail_position_error_m")
    at = f" at day {when / 86400.0:.2f}" if isinstance(when, float) and math.isfinite(when) else ""
    off = f", {row['spacecraft']} {size / 1e3:.3g} km off" if isinstance(size, float) and math.isfinite(size) else ""
    return f"run {row['run']}: {reason}{at}{off}"
