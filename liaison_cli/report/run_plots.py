"""Figures of one `liaison run` result (`liaison plot run`), each as PNG and SVG:

- errors: per spacecraft, the position and velocity error norms of every run (faint) and of one highlighted
  run, against that run's 3-sigma norm (shaded below it), on log axes;
- nees: the run-averaged NEES against its two-sided 95 % chi-square band (analysis.metrics.nees_band); for an
  estimator with one NEES per solution (a batch), each run's against the single-run band, by run;
- innovations: per link and observable, the innovations (a batch's post-fit residuals, so labelled) divided by
  their predicted standard deviation, with the +-3 lines and the residual gate's rejections marked;
- clocks (with clock states, or a batch's clock_sync fits): per clock, phase and frequency errors with the
  highlighted run's +-3 sigma;
- bias (with range biases estimated or considered): per link and run, estimate - truth with +-3 sigma bars;
- ric and directions: the consistency figures of report.consistency_plots.

Time axes are days from t0, with t0's date on the TDB scale for a dated run; the errors and NEES figures mark
the settle time after which the run text judges consistency (from the result's metadata).

Faint lines and points are rasterised inside the SVG so that it stays small for many runs."""

from pathlib import Path

import numpy as np

from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.report.consistency_plots import draw_directions, draw_ric
from liaison_cli.report.run_result import RunResult

FAINT = {"color": "0.55", "alpha": 0.35, "linewidth": 0.7, "rasterized": True}
HIGHLIGHT = "tab:blue"
SIGMA_COLOUR = "tab:orange"
MAX_FAINT_RUNS = 30  # runs drawn faint in the innovation panels (points add up fast)


def draw_run(result: RunResult, out_dir, highlight: int) -> list[Path]:
    """Draw every figure the result has data for into out_dir; returns the files written."""
    import matplotlib

    matplotlib.use("Agg")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for stem, draw in (("errors", _draw_errors), ("nees", _draw_nees), ("innovations", _draw_innovations),
                       ("clocks", _draw_clocks), ("bias", _draw_bias), ("ric", draw_ric),
                       ("directions", draw_directions)):
        fig = draw(result, highlight)
        if fig is not None:
            paths += _save(fig, out_dir / stem)
    return paths


def _save(fig, stem: Path) -> list[Path]:
    """PNG and SVG, each written beside its place and renamed over it (never a half-written figure)."""
    import matplotlib.pyplot as plt

    paths = []
    for suffix in (".png", ".svg"):
        path = stem.with_suffix(suffix)
        tmp = path.with_name(f".{path.name}.tmp{suffix}")
        fig.savefig(tmp, dpi=120)
        # The SVG keeps the layout the PNG's drawing placed: constrained layout measures every artist, the runs'
        # long lines included, and was about 40 % of `plot run`'s time when it ran again for the SVG.
        fig.set_layout_engine("none")
        tmp.replace(path)
        paths.append(path)
    plt.close(fig)
    return paths


def _other_runs_faint(ax, table, column: str, highlight: int):
    """Every run but the highlighted one as a faint line of `column`; returns the highlighted run's rows and
    their times in days."""
    for run, group in table.groupby("run"):
        if run != highlight:
            ax.plot(_days(group.t_s), group[column], **FAINT)
    chosen = table[table.run == highlight]
    return chosen, _days(chosen.t_s)


def _days(t_s) -> np.ndarray:
    return np.asarray(t_s, dtype=float) / SECONDS_PER_DAY


def time_label(result: RunResult) -> str:
    """The time axis' label: days from t0, and t0's date on the TDB scale for a dated run (timeseries'
    epoch_tdb)."""
    series = result.timeseries
    if "epoch_tdb" in series.columns and len(series):
        first = series.iloc[0]
        t0 = np.datetime64(first.epoch_tdb, "ns") - np.timedelta64(int(round(float(first.t_s) * 1e9)), "ns")
        return f"days from t0 = {np.datetime_as_string(t0, unit='s').replace('T', ' ')} TDB"
    return "time (days from t0)"


def mark_settle(ax, result: RunResult) -> None:
    """A dashed line at the settle time, after which the run text judges consistency (when the result says it)."""
    if np.isfinite(result.settle_days):
        ax.axvline(result.settle_days, color="0.3", linestyle="--", linewidth=0.9, label="settle time")


def _draw_errors(result: RunResult, highlight: int):
    import matplotlib.pyplot as plt

    series = result.timeseries
    spacecraft = list(dict.fromkeys(series.spacecraft))
    if not spacecraft:
        return None
    fig, axes = plt.subplots(len(spacecraft), 2, figsize=(11, 2.6 * len(spacecraft) + 0.8), squeeze=False,
                             sharex=True, layout="constrained")
    runs = series.run.nunique()
    for row, name in enumerate(spacecraft):
        mine = series[series.spacecraft == name]
        for col, (error, sigma, unit) in enumerate((("position_error_m", "position_3sigma_m", "m"),
                                                    ("velocity_error_m_s", "velocity_3sigma_m_s", "m/s"))):
            ax = axes[row, col]
            chosen, t = _other_runs_faint(ax, mine, error, highlight)
            ax.fill_between(t, 0, chosen[sigma], color=SIGMA_COLOUR, alpha=0.15, linewidth=0)
            ax.plot(t, chosen[sigma], color=SIGMA_COLOUR, linewidth=1.2, label=f"3σ (run {highlight})")
            ax.plot(t, chosen[error], color=HIGHLIGHT, linewidth=1.0, label=f"error, run {highlight}")
            _log_scale(ax, mine[[error, sigma]].to_numpy(), always=True)  # every panel alike (issue 47)
            mark_settle(ax, result)
            ax.set_ylabel(f"{name} {error.split('_')[0]} ({unit})")
            ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel(time_label(result))
    fig.suptitle(f"{result.name}: estimation error norms, {_runs_phrase(runs, highlight)}, with its 3σ norm")
    return fig


def _runs_phrase(runs: int, highlight: int) -> str:
    return f"run {highlight}" if runs == 1 else f"{runs} runs (grey; run {highlight} in colour)"


def _log_scale(ax, values: np.ndarray, always: bool = False) -> None:
    """Log y when the values are positive and span more than a decade (errors shrink by orders as the filter
    converges), or `always` (the error figure: its panels alike, as its description says); linear otherwise."""
    finite = values[np.isfinite(values) & (values > 0)]
    if finite.size and (always or finite.max() / finite.min() > 10):
        ax.set_yscale("log")
        ax.set_ylim(bottom=max(finite.min(), finite.max() * 1e-8) / 2)


def _draw_nees(result: RunResult, highlight: int):
    import matplotlib.pyplot as plt

    from liaison_cli.estimation.estimators import ESTIMATORS

    table = result.consistency
    if table.empty:
        return None
    estimator = ESTIMATORS.get(result.estimator)
    if estimator is not None and not estimator.nees_per_epoch:
        return _draw_nees_per_solution(result, highlight, int(table.state_size.max()))
    fig, ax = plt.subplots(figsize=(11, 4), layout="constrained")
    t = _days(table.t_s)
    ax.fill_between(t, table.band_low, table.band_high, color="tab:green", alpha=0.2, linewidth=0,
                    label="95 % χ² band of the mean")
    ax.plot(t, table.mean_nees, color=HIGHLIGHT, linewidth=1.0, label="NEES averaged over the runs")
    _log_scale(ax, table[["mean_nees", "band_low", "band_high"]].to_numpy())
    mark_settle(ax, result)
    inside = 100.0 * float(np.mean(table.inside_band)) if len(table) else float("nan")
    runs, states = int(table.runs.max()), int(table.state_size.max())
    ax.set_title(f"{result.name}: run-averaged NEES test, band χ²({runs}·{states})/{runs} at 95 %: inside at "
                 f"{inside:.0f} % of all epochs\n(the run text's verdict is the single-run band test after the "
                 "settle time: analysis.consistency)", fontsize=10)
    ax.set_xlabel(time_label(result))
    ax.set_ylabel("NEES")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    return fig


def _draw_nees_per_solution(result: RunResult, highlight: int, states: int):
    """An estimator with one NEES per run and solution (a batch: its epoch state's, the same at every epoch the
    solution covers): each solution's NEES by run against the single-run two-sided 95 % chi-square band of its
    states, and the runs' mean against the band of the mean; a per-epoch line would only repeat each number."""
    import matplotlib.pyplot as plt

    from liaison_cli.analysis.metrics import chi2_quantile

    series = result.timeseries.dropna(subset=["nees"]).drop_duplicates(["run", "nees"])
    if series.empty:
        return None
    runs = series.run.nunique()
    low, high = chi2_quantile(0.025, states), chi2_quantile(0.975, states)
    mean_low, mean_high = chi2_quantile(0.025, states * runs) / runs, chi2_quantile(0.975, states * runs) / runs
    fig, ax = plt.subplots(figsize=(11, 4), layout="constrained")
    ax.axhspan(low, high, color="tab:green", alpha=0.2, linewidth=0, label=f"95 % χ²({states}) band of one run")
    ax.axhspan(mean_low, mean_high, color="tab:purple", alpha=0.15, linewidth=0,
               label=f"95 % band of the mean of {runs}")
    others = series[series.run != highlight]
    ax.plot(others.run, others.nees, "o", color="0.45", markersize=3, label="NEES of a solution")
    mine = series[series.run == highlight]
    ax.plot(mine.run, mine.nees, "o", color=HIGHLIGHT, markersize=4, label=f"run {highlight}")
    mean = float(series.groupby("run").nees.first().mean())
    ax.axhline(mean, color="tab:purple", linewidth=1.0, label=f"mean of the runs' first solutions: {mean:.3g}")
    inside = int(((series.nees >= low) & (series.nees <= high)).sum())
    _log_scale(ax, np.array([*series.nees, low, high]))
    ax.set_title(f"{result.name}: NEES of each run's {result.estimator} solution ({states} states): inside the "
                 f"single-run band for {inside} of {len(series)}\n(one number per run and solution: its epoch "
                 "state's error against its covariance, the same at every epoch it covers)", fontsize=10)
    ax.set_xlabel("run")
    ax.set_ylabel("NEES")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    return fig


def _draw_innovations(result: RunResult, highlight: int):
    import matplotlib.pyplot as plt

    from liaison_cli.estimation.estimators import ESTIMATORS

    estimator = ESTIMATORS.get(result.estimator)  # None: a result whose metadata does not say
    table, left_out = _channels_the_estimator_reads(result.residuals, estimator)
    if table.empty:
        return None
    channels = list(table.groupby(["link", "observable"], sort=False).groups)
    ncol = 2 if len(channels) > 1 else 1
    nrow = -(-len(channels) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(11, 2.6 * nrow + 1.0), squeeze=False, sharex=True,
                             layout="constrained")
    faint_runs = set(sorted(table.run.unique())[:MAX_FAINT_RUNS]) - {highlight}
    kind = estimator.residuals if estimator is not None else "innovations"  # "post-fit residuals" of a batch
    for ax, (link, observable) in zip(axes.flat, channels):
        mine = table[(table.link == link) & (table.observable == observable)]
        normalised = mine.innovation / mine.innovation_std
        faint = mine.run.isin(faint_runs)
        ax.plot(_days(mine.t_s[faint]), normalised[faint], ".", color="0.55", alpha=0.3, markersize=1.5,
                rasterized=True)
        chosen = mine.run == highlight
        ax.plot(_days(mine.t_s[chosen]), normalised[chosen], ".", color=HIGHLIGHT, markersize=2.5,
                label=f"run {highlight}")
        rejected = mine.rejected.astype(bool)
        if rejected.any():
            ax.plot(_days(mine.t_s[rejected]), normalised[rejected], "x", color="tab:red", markersize=4,
                    label="rejected by the gate")
        for level in (-3, 3):
            ax.axhline(level, color=SIGMA_COLOUR, linewidth=1.0)
        spread = np.nanpercentile(np.abs(normalised), 99.5) if normalised.notna().any() else 3.0
        ax.set_ylim(-max(4.0, 1.2 * spread), max(4.0, 1.2 * spread))
        ax.set_ylabel(f"{kind.removesuffix('s')} / σ")
        ax.set_title(f"{link}: {observable} ({mine.unit.iloc[0]})", fontsize=9)
        ax.grid(True, alpha=0.3)
    for ax in axes.flat[len(channels):]:
        ax.set_visible(False)
    axes.flat[0].legend(loc="upper right", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel(time_label(result))
    runs = table.run.nunique()
    shown = "" if len(faint_runs) + 1 == runs else f" ({len(faint_runs)} of the others drawn)"
    note = f"\n({', '.join(left_out)}: read by clock_sync, not by the {result.estimator}; not drawn)" if left_out else ""
    fig.suptitle(f"{result.name}: normalised {kind}, {_runs_phrase(runs, highlight)}{shown}; ±3 lines{note}")
    return fig


def _channels_the_estimator_reads(table, estimator):
    """(the residual rows of the channels the estimator updates with, the observables left out): an estimator
    without clock states (the batch) does not use clock-offset channels; clock_sync does, so their residuals
    are raw clock offsets, hundreds of their sigma, not innovations."""
    from liaison_cli.measurements.registry import OBSERVABLES

    if table.empty or estimator is None or estimator.carries_clocks:
        return table, []
    clock_offsets = {o.channels[o.clock_offset_channel].label for o in OBSERVABLES.values()
                     if o.clock_offset_channel >= 0}
    dropped = table.observable.isin(clock_offsets)
    return table[~dropped], sorted(set(table.observable[dropped]))


def _draw_clocks(result: RunResult, highlight: int):
    import matplotlib.pyplot as plt

    table = result.clocks
    if table.empty:
        return None
    clocks = list(dict.fromkeys(table["clock"]))
    fig, axes = plt.subplots(len(clocks), 2, figsize=(11, 2.6 * len(clocks) + 0.8), squeeze=False, sharex=True,
                             layout="constrained")
    for row, name in enumerate(clocks):
        mine = table[table["clock"] == name]
        for col, (error, sigma, label) in enumerate((("phase_error_ns", "phase_sigma_ns", "phase (ns)"),
                                                     ("frequency_error", "frequency_sigma", "frequency (s/s)"))):
            ax = axes[row, col]
            chosen, t = _other_runs_faint(ax, mine, error, highlight)
            ax.fill_between(t, -3 * chosen[sigma], 3 * chosen[sigma], color=SIGMA_COLOUR, alpha=0.2, linewidth=0,
                            label=f"±3σ (run {highlight})")
            ax.plot(t, chosen[error], color=HIGHLIGHT, linewidth=1.0, label=f"error, run {highlight}")
            ax.set_ylabel(f"{name} {label}")
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel(time_label(result))
    from liaison_cli.estimation.estimators import ESTIMATORS

    estimator = ESTIMATORS.get(result.estimator)
    fitted = estimator is not None and not estimator.carries_clocks  # a batch's clocks: clock_sync's fits
    what = ("clock_sync's fitted clocks (each relative to its link's receiver), over the sync window and the "
            "prediction" if fitted else "clock estimation errors")
    fig.suptitle(f"{result.name}: {what}, {_runs_phrase(table.run.nunique(), highlight)}, with its ±3σ")
    return fig


def _draw_bias(result: RunResult, highlight: int):
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    table = result.bias
    if table.empty or (table.treatment == "ignore").all():
        return None
    table = table[table.treatment != "ignore"]
    links = list(dict.fromkeys(table.link))
    fig, axes = plt.subplots(len(links), 1, figsize=(11, 2.6 * len(links) + 1.0), squeeze=False,
                             layout="constrained")
    for ax, link in zip(axes[:, 0], links):
        mine = table[table.link == link]
        miss = mine.bias_estimate_m - mine.bias_true_m
        ax.errorbar(mine.run, miss, yerr=3 * mine.bias_sigma_m, fmt="o", color="0.45", markersize=3,
                    elinewidth=0.8, capsize=2, label="estimate − truth, ±3σ")
        chosen = mine.run == highlight
        ax.plot(mine.run[chosen], miss[chosen], "o", color=HIGHLIGHT, markersize=5, label=f"run {highlight}")
        ax.axhline(0.0, color="black", linewidth=0.8)
        ax.set_ylabel("range bias (m)")
        ax.set_title(f"{link} ({mine.treatment.iloc[0]})", fontsize=9)
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(loc="upper right", fontsize=8)
    axes[-1, 0].set_xlabel("run")
    axes[-1, 0].xaxis.set_major_locator(MaxNLocator(integer=True))
    fig.suptitle(f"{result.name}: range-bias estimates at the end of each run")
    return fig
