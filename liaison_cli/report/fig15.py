"""Turan et al. (2022) Fig. 15 analogue: orbit-determination RMS error against the crosslink ranging sigma.

One line per (formation, spacecraft): the mean over Monte Carlo runs of each run's RMS error (the statistic
of Table 3), a shaded 10-90 % band across runs, and the paper's Table 3 values as open markers.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.errors import LiaisonError, UnreadableFileError

FORMATION_LABELS = {"eml2_lunar": "EML2 halo – lunar", "eml1_lunar": "EML1 halo – lunar",
                    "eml1_eml2": "EML1 halo – EML2 halo"}
PANELS = (
    ("rms_position_m", "position_rms_m", 1.0, "Position error RMS [m]"),
    ("rms_velocity_m_s", "velocity_rms_m_s", 1e3, "Velocity error RMS [mm/s]"),
)


class PlotError(LiaisonError):
    """The result folder cannot be plotted as requested."""


def load_curve(sweep_dir) -> pd.DataFrame:
    path = Path(sweep_dir) / "curve.parquet"
    if not path.exists():
        raise PlotError(f"{sweep_dir}: no curve.parquet here; give a folder written by 'liaison sweep'")
    try:
        curve = pd.read_parquet(path)
    except (OSError, ValueError) as exc:  # pyarrow: ArrowInvalid is a ValueError, ArrowIOError an OSError
        raise UnreadableFileError(f"{path}: not a readable Parquet table ({type(exc).__name__}: "
                                  f"{str(exc).splitlines()[0] if str(exc) else 'no detail'}); rerun the sweep "
                                  "to rebuild it from its manifest") from None
    if curve.groupby(["scenario", "spacecraft"]).sigma_m.nunique().max() < 2:
        raise PlotError(f"{path}: sigma_m takes fewer than 2 values per scenario; Fig. 15 needs a --sigma sweep")
    return curve


def sigma_series(curve: pd.DataFrame):
    """(scenario, spacecraft, rows sorted by sigma) with one row per sigma (other grid keys must be fixed)."""
    for (scenario, spacecraft), rows in curve.groupby(["scenario", "spacecraft"], sort=False):
        if rows.sigma_m.duplicated().any():
            raise PlotError(
                f"scenario {scenario!r} has several grid points per sigma (another --grid key varies); "
                "Fig. 15 needs sigma as the only swept key"
            )
        yield scenario, spacecraft, rows.sort_values("sigma_m")


def consistent_mask(rows: pd.DataFrame) -> np.ndarray:
    """True where the curve's point passes the consistency verdict (consistent_settled), or where the curve
    predates the column (nothing to mark); False where it fails."""
    if "consistent_settled" not in rows:
        return np.ones(len(rows), dtype=bool)
    return rows.consistent_settled.fillna(True).to_numpy(dtype=bool)


def draw_fig15(curve: pd.DataFrame, paper: pd.DataFrame, out_stem, title: str | None = None) -> list[Path]:
    """Write <out_stem>.png and .svg; returns the paths. `paper`: the paper's Table 3
    (campaign.studies.table3.paper_table3)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    colours = plt.get_cmap("tab10")
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2), constrained_layout=True)
    series = list(sigma_series(curve))
    styles = ["-", "--", ":", "-."]
    for k, (scenario, spacecraft, rows) in enumerate(series):
        colour = colours(k % 10)
        members = [s for sc, s, _ in series if sc == scenario]
        style = styles[members.index(spacecraft) % len(styles)]
        label = f"{FORMATION_LABELS.get(scenario, scenario)}: {spacecraft}"
        ref = paper[(paper.formation == scenario) & (paper.spacecraft == spacecraft)]
        for ax, (metric, paper_col, scale, _) in zip(axes, PANELS):
            sigma = rows.sigma_m.to_numpy()
            ax.fill_between(sigma, scale * rows[f"{metric}_p10"], scale * rows[f"{metric}_p90"],
                            color=colour, alpha=0.12, linewidth=0)
            ax.plot(sigma, scale * rows[f"{metric}_mean"], style, color=colour, linewidth=1.8, label=label)
            failed = ~consistent_mask(rows)
            if failed.any():  # the consistency verdict where users look: a cross on each sigma it fails
                ax.plot(sigma[failed], scale * rows[f"{metric}_mean"].to_numpy()[failed], "x", color=colour,
                        mew=1.6, ms=7)
            if len(ref):
                ax.plot(ref.sigma_m, scale * ref[paper_col], "o", mfc="none", mec=colour, mew=1.8, ms=8)
    for ax, (_, _, _, ylabel) in zip(axes, PANELS):
        ax.set_xlabel("Crosslink ranging error σ [m] (1σ)")
        ax.set_ylabel(ylabel)
        ax.set_yscale("log")
        ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
        ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.grid(True, which="both", alpha=0.3)
    runs = int(curve.runs.max())
    handles, labels = axes[0].get_legend_handles_labels()
    handles += [Line2D([], [], marker="o", mfc="none", mec="black", ls="none", ms=8),
                Line2D([], [], color="grey", alpha=0.3, linewidth=8)]
    labels += ["Turan et al. 2022, Table 3", f"10–90 % of {runs} Monte Carlo runs"]
    marked = sum(int((~consistent_mask(rows)).sum()) for _, _, rows in series)
    if marked:
        handles.append(Line2D([], [], marker="x", color="black", ls="none", mew=1.6, ms=7))
        labels.append(f"filter not consistent at this σ ({marked} of {sum(len(r) for _, _, r in series)} points; "
                      "curve.parquet: consistency_failed)")
    fig.legend(handles, labels, loc="outside lower center", ncol=4, fontsize=9, frameon=False)
    fig.suptitle(title or "Orbit-determination error vs crosslink ranging error (cf. Turan et al. 2022, Fig. 15)")
    out_stem = Path(out_stem)
    out_stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    for suffix in (".png", ".svg"):
        path = out_stem.with_suffix(suffix)
        tmp = path.with_name(f".{path.name}.tmp{suffix}")
        fig.savefig(tmp, dpi=130, metadata={"Date": None} if suffix == ".svg" else None)
        tmp.replace(path)
        paths.append(path)
    plt.close(fig)
    return paths


def paper_points_vs_curve(curve: pd.DataFrame, paper: pd.DataFrame) -> pd.DataFrame:
    """Paper Table 3 values (`paper`) beside our curve (interpolated in sigma); ratio = ours / paper."""
    rows = []
    for scenario, spacecraft, series in sigma_series(curve):
        ref = paper[(paper.formation == scenario) & (paper.spacecraft == spacecraft)]
        for item in ref.itertuples():
            for metric, paper_col, _, _ in PANELS:
                sigma = series.sigma_m.to_numpy(dtype=float)
                if not sigma.min() <= item.sigma_m <= sigma.max():
                    continue
                ours = float(np.interp(item.sigma_m, sigma, series[f"{metric}_mean"].to_numpy(dtype=float)))
                rows.append({"scenario": scenario, "spacecraft": spacecraft, "sigma_m": item.sigma_m,
                             "metric": metric, "ours": ours, "paper": getattr(item, paper_col),
                             "ratio": ours / getattr(item, paper_col)})
    return pd.DataFrame(rows)
