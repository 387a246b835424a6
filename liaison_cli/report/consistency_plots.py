"""Consistency figures of one `liaison run` result (`liaison plot run`), from its summary table:

- ric: per spacecraft, the position and velocity errors along the radial, in-track and cross-track axes after
  the settle time (about the nearer primary: analysis.ric): error RMS, mean error (a bias) and the filter's
  sigma RMS over the healthy runs, side by side, so an axis whose error outgrows its sigma stands out (the
  batch has no sigma along these axes: its bars are the errors only);
- directions: each healthy run's NEES after the settle time split as the run text splits it (whole state,
  each spacecraft's own 6 states, the common time shift, the linked pair's line of sight), and each
  measurement channel's mean NIS (links.parquet), each divided by what a consistent filter gives (its state
  count, 6, 1, 1, 1), on a log axis around 1.

Both use the same settled epochs and the same statistics as the run text and the verdict (analysis.consistency),
and say so in their titles."""

import numpy as np

from liaison_cli.report.run_result import RunResult

AXES = ("radial", "intrack", "crosstrack")
AXIS_LABELS = ("radial", "in-track", "cross-track")
# (column stem, unit in the table, unit shown, factor)
QUANTITIES = (("position", "m", "m", 1.0), ("velocity", "m_s", "mm/s", 1e3))


def _healthy(result: RunResult):
    table = result.summary
    return table[table.status == "ok"] if "status" in table else table


def draw_ric(result: RunResult, highlight: int):
    """Grouped bars per axis: error RMS, |mean error| and sigma RMS, each the mean over the healthy runs of the
    run's own value, as the run text's RIC table gives them (report.run_text.format_ric; the bars had taken the
    RMS over the runs, 2-5 % above the text under the same label: issue 47). None: no RIC columns."""
    import matplotlib.pyplot as plt

    table = _healthy(result)
    if table.empty or "rms_radial_position_settled_m" not in table or table.rms_radial_position_settled_m.isna().all():
        return None
    names = list(dict.fromkeys(table.spacecraft))
    fig, axes = plt.subplots(2, len(names), figsize=(11, 6.2), squeeze=False, layout="constrained")
    width = 0.26
    for col, name in enumerate(names):
        rows = table[table.spacecraft == name]
        for row, (stem, unit, shown, factor) in enumerate(QUANTITIES):
            ax = axes[row, col]
            rms = [_finite_mean(rows[f"rms_{a}_{stem}_settled_{unit}"]) * factor for a in AXES]
            bias = [abs(_finite_mean(rows[f"mean_{a}_{stem}_settled_{unit}"])) * factor for a in AXES]
            sigma = [_finite_mean(rows[f"sigma_{a}_{stem}_settled_{unit}"]) * factor for a in AXES]
            x = np.arange(len(AXES))
            ax.bar(x - width, rms, width, color="tab:blue", label="error RMS")
            ax.bar(x, bias, width, color="tab:red", label="|mean error|")
            ax.bar(x + width, sigma, width, color="tab:orange", label="σ RMS")
            ax.set_xticks(x, AXIS_LABELS, fontsize=8)
            ax.set_ylabel(f"{stem} ({shown})")
            ax.grid(True, axis="y", alpha=0.3)
            if row == 0:
                ax.set_title(f"{name} ({len(rows)} healthy run{'s' if len(rows) != 1 else ''})", fontsize=9)
    axes[0, 0].legend(loc="upper left", fontsize=7)
    fig.suptitle(f"{result.name}: errors in each spacecraft's radial / in-track / cross-track frame after the "
                 "settle time (about the nearer primary; means over the runs, as the run text)", fontsize=10)
    return fig


def _finite_mean(values) -> float:
    """The mean of the finite values; NaN when there are none (a batch has no sigma per epoch: no bar)."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(values.mean()) if values.size else float("nan")


def _direction_ratios(result: RunResult):
    """[(label, values per healthy run and spacecraft row divided by their consistent value)]."""
    table = _healthy(result)
    runs = table.drop_duplicates("run")
    out = []
    if "state_size" in result.consistency and not result.consistency.empty:
        states = int(result.consistency.state_size.max())
        out.append((f"whole state (÷ {states})", runs.mean_nees_settled / states))
    out += [(f"{name}'s own 6 states (÷ 6)", rows.mean_nees_spacecraft_settled / 6.0)
            for name, rows in table.groupby("spacecraft", sort=False)]
    out.append(("common time shift (÷ 1)", runs.time_shift_nees_settled))
    if runs.along_link_nees_settled.notna().any():
        pairs = ", ".join(sorted({p for p in runs.along_link_pair if p}))
        out.append((f"line of sight {pairs} (÷ 1)", runs.along_link_nees_settled))
    links = result.links
    if links is not None and not links.empty:
        healthy = links[links.run.isin(set(runs.run))]
        for (link, observable), rows in healthy.groupby(["link", "observable"], sort=False):
            out.append((f"NIS {link} {observable} (÷ 1)", rows.mean_nis_settled))
    return [(label, np.asarray(values, dtype=float)) for label, values in out]


def draw_directions(result: RunResult, highlight: int):
    """Each run's NEES components after the settle time over their consistent values (None: no such columns)."""
    import matplotlib.pyplot as plt

    table = _healthy(result)
    if table.empty or "time_shift_nees_settled" not in table or table.time_shift_nees_settled.isna().all():
        return None
    ratios = _direction_ratios(result)
    fig, ax = plt.subplots(figsize=(11, 1.0 + 0.8 * len(ratios)), layout="constrained")
    rng = np.random.default_rng(0)  # a fixed jitter: the same figure every time
    for y, (label, values) in enumerate(ratios):
        finite = values[np.isfinite(values) & (values > 0)]
        ax.plot(finite, y + rng.uniform(-0.15, 0.15, finite.size), ".", color="tab:blue", alpha=0.6)
        if finite.size:
            ax.plot([np.mean(finite)] * 2, [y - 0.3, y + 0.3], color="tab:red", linewidth=2.0)
    ax.axvline(1.0, color="tab:green", linewidth=1.2)
    ax.set_xscale("log")
    ax.invert_yaxis()  # the whole state on top, as in the run text
    ax.set_yticks(range(len(ratios)), [label for label, _ in ratios], fontsize=8)
    ax.set_xlabel("mean NEES component or NIS / its consistent value (1; right of it: optimistic)")
    ax.grid(True, which="both", axis="x", alpha=0.3)
    ax.set_title(f"{result.name}: NEES by direction and NIS by channel after the settle time, a dot per healthy "
                 "run (red: their mean)", fontsize=10)
    return fig
