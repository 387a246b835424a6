"""003's study as a table and figures: the 3D RMS table, per-mission histories (the analogue of 003 Figs.
2-5, 8-9, 12-13) and the departing spacecraft's error for the three missions (the analogue of Fig. 15)."""

from pathlib import Path

import numpy as np
import pandas as pd

CASE_TITLES = {"full": "DSN + LiAISON", "dsn_only": "DSN only", "liaison_only": "LiAISON only"}


def _fmt(value: float, scale: float, digits: int) -> str:
    return "—" if not np.isfinite(value) else f"{value * scale:.{digits}f}"


def format_table(summary: pd.DataFrame, grid_keys=(), settle_days: float = 1.0) -> str:
    """Markdown: per grid point (if any), mission, case and spacecraft the 3D RMS of the formal sigma (RSS
    over the axes, and per axis: 003's "3D RMS" read both ways) and of the error, over the 9 days and after
    the settle time, their ratio and the NEES share in band; '!' marks a spacecraft that fails the
    consistency verdict (analysis.consistency)."""
    import math

    from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT

    out = []
    groups = summary.groupby(list(grid_keys), sort=False) if grid_keys else [((), summary)]
    for values, part in groups:
        if grid_keys:
            values = values if isinstance(values, tuple) else (values,)
            out.append("**" + ", ".join(f"{k} = {v}" for k, v in zip(grid_keys, values)) + "**\n")
        out += [f"| mission | case | spacecraft | σ pos m: 9 d RSS [per axis] | 003 | σ > {settle_days:g} d | "
                f"error 9 d | error > {settle_days:g} d | err/σ > {settle_days:g} d | NEES in band | σ vel mm/s 9 d | "
                "003 | err/σ vel | inside 3σ | runs ok |",
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in part.itertuples():
            mark = "" if r.consistent_settled else " !"
            out.append(
                f"| {r.mission} | {CASE_TITLES[r.case]} | {r.spacecraft}{mark} | "
                f"{_fmt(r.sigma3d_rms_position_m, 1, 1)} [{_fmt(r.sigma3d_rms_position_m / math.sqrt(3), 1, 1)}] | "
                f"{_fmt(r.paper_sigma3d_rms_position_m, 1, 0)} | {_fmt(r.sigma3d_rms_position_m_settled, 1, 1)} | "
                f"{_fmt(r.error3d_rms_position_m, 1, 1)} | {_fmt(r.error3d_rms_position_m_settled, 1, 1)} | "
                f"{r.error_to_sigma_position_settled:.2f} | {100 * r.frac_nees_in_band_settled:.0f} % | "
                f"{_fmt(r.sigma3d_rms_velocity_m_s, 1e3, 2)} | {_fmt(r.paper_sigma3d_rms_velocity_m_s, 1e3, 2)} | "
                f"{r.error_to_sigma_velocity_settled:.2f} | {100 * r.inside_3sigma_position:.1f} % | "
                f"{r.runs_ok}/{r.runs} |")
        out.append("")
    out.append("! marks a spacecraft that fails the consistency verdict after the settle time (analysis.consistency: "
               "the NEES test, whole state and its own states, and the error/σ ratio's 95 % interval against "
               f"[{1 / CONSISTENCY_RATIO_LIMIT:.2f}, {CONSISTENCY_RATIO_LIMIT:g}]; the Parquet's consistency_failed says which).")
    return "\n".join(out) + "\n"


def save_png(fig, path: Path) -> Path:
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=110)
    tmp.replace(path)
    return path


def pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def draw_mission(history: pd.DataFrame, mission: str, out_dir: Path) -> Path:
    """Rows: navigation position / velocity, departure position / velocity; columns: the three cases.
    Solid: RMS over the runs of the error norm; dashed: the mean 3-sigma bound of the norm."""
    plt = pyplot()
    data = history[history.mission == mission]
    panels = [(role, quantity) for role in ("navigation", "departure") for quantity in ("position", "velocity")]
    fig, axes = plt.subplots(len(panels), 3, figsize=(13, 11), sharex=True, squeeze=False)
    for col, case in enumerate(CASE_TITLES):
        for row, (role, quantity) in enumerate(panels):
            ax = axes[row, col]
            part = data[(data.case == case) & (data.role == role) & (data.quantity == quantity)]
            scale, unit = (1.0, "m") if quantity == "position" else (1e3, "mm/s")
            ax.semilogy(part.t_days, part.error_rms * scale, color="tab:blue", lw=1, label="error RMS")
            ax.semilogy(part.t_days, part.bound_3sigma * scale, color="tab:red", lw=1, ls="--", label="3σ")
            if col == 0:
                name = part.spacecraft.iloc[0] if len(part) else role
                ax.set_ylabel(f"{name} {quantity} ({unit})")
            if row == 0:
                ax.set_title(CASE_TITLES[case])
            ax.grid(True, which="both", alpha=0.3)
        axes[-1, col].set_xlabel("days")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{mission}: error norm (RMS over runs) and 3σ bound")
    fig.tight_layout()
    path = save_png(fig, out_dir / f"{mission}_histories.png")
    plt.close(fig)
    return path


def draw_comparison(history: pd.DataFrame, out_dir: Path) -> Path:
    """The departing spacecraft's position error RMS, one line per mission, one panel per case."""
    plt = pyplot()
    data = history[(history.role == "departure") & (history.quantity == "position")]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), sharey=True)
    for ax, case in zip(axes, CASE_TITLES):
        for mission, part in data[data.case == case].groupby("mission"):
            ax.semilogy(part.t_days, part.error_rms, lw=1, label=mission)
        ax.set_title(CASE_TITLES[case])
        ax.set_xlabel("days")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("departing spacecraft position error RMS (m)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    path = save_png(fig, out_dir / "departures_position_error.png")
    plt.close(fig)
    return path
