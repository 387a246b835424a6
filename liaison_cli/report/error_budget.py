"""The error budget (campaign.studies.error_budget) as Markdown tables and the ODTBX-style stacked-area picture.
Formats and draws only."""

from pathlib import Path

import numpy as np

from liaison_cli.dynamics.constants import SECONDS_PER_DAY

COLOURS = {"initial": "tab:blue", "noise": "tab:orange", "process": "tab:green", "bias": "tab:red",
           "measurement_model": "tab:purple", "dynamics_model": "tab:brown", "cr": "tab:olive", "moon_gm": "tab:cyan"}


def format_shares(share_rows_all: list[dict], share_rows_late: list[dict]) -> str:
    """Markdown: each source's share of the mean-square position / velocity error, all epochs and after day 1."""
    late = {(r["spacecraft"], r["part"]): r for r in share_rows_late}
    lines = ["| spacecraft | part | position share | after day 1 | velocity share | after day 1 | position RMS m |",
             "|---|---|---|---|---|---|---|"]
    for row in share_rows_all:
        other = late[(row["spacecraft"], row["part"])]
        if row["part"] != "total" and abs(row["position_share"]) < 5e-4 and abs(other["position_share"]) < 5e-4:
            continue
        lines.append(f"| {row['spacecraft']} | {row['part']} | {100 * row['position_share']:.1f} % | "
                     f"{100 * other['position_share']:.1f} % | {100 * row['velocity_share']:.1f} % | "
                     f"{100 * other['velocity_share']:.1f} % | {row['position_rms_m']:.1f} |")
    return "\n".join(lines) + "\n"


def draw_budget(budget, grouped: dict, path: Path, title: str) -> Path:
    """Stacked areas of each source's RMS-squared contribution (`grouped`: {source: (m, n_sc, 2)},
    campaign.studies.budget_tables.by_source), per spacecraft, position and velocity; the filter's own trace(P)
    as a line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n_sc = len(budget.spacecraft)
    days = budget.times_s / SECONDS_PER_DAY
    fig, axes = plt.subplots(2, n_sc, figsize=(5.5 * n_sc, 7), squeeze=False, sharex=True)
    for i, name in enumerate(budget.spacecraft):
        for row, (unit, scale) in enumerate((("m²", 1.0), ("(mm/s)²", 1e3))):
            ax = axes[row, i]
            layers = [(src, np.clip(values[:, i, row], 0.0, None) * scale**2) for src, values in grouped.items()
                      if np.any(np.abs(values[:, i, row]) > 1e-4 * np.max(budget.total[:, i, row]))]
            ax.stackplot(days, *[v for _, v in layers], labels=[s for s, _ in layers],
                         colors=[COLOURS.get(s, "grey") for s, _ in layers], alpha=0.85)
            ax.plot(days, budget.filter_variance[:, i, row] * scale**2, color="black", lw=1, ls="--",
                    label="filter trace(P)")
            # Linear axes keep the stacked areas proportional; the first day's transient is cut off at
            # 1.5 x the largest total after it.
            late = budget.times_s >= SECONDS_PER_DAY
            top = float(np.max(budget.total[late, i, row])) * scale**2 if late.any() else None
            if top:
                ax.set_ylim(0.0, 1.5 * top)
            ax.set_ylabel(f"{'position' if row == 0 else 'velocity'} error² ({unit})")
            ax.set_title(f"{name}: {'position' if row == 0 else 'velocity'}", fontsize=10)
            ax.grid(True, alpha=0.3)
        axes[1, i].set_xlabel("days")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=len(labels), fontsize=9, frameon=False)
    fig.suptitle(f"{title}\n(linear axes keep the areas proportional; the first day's transient runs above the top, "
                 "cut at 1.5 x the largest total after day 1)", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    tmp.replace(path)
    plt.close(fig)
    return path


def format_budget_consistency(rows: list[dict], settle_days: float, nees_share: float | None = None,
                       check_runs: int = 0) -> str:
    """Per spacecraft after the settle time: the budget's error RMS, the filter's sigma RMS and their ratio
    for position and velocity ('!' outside [1/1.5, 1.5]: the ratio test of analysis.consistency), and the check runs' NEES-in-band share when there were
    check runs; a closing line names the inconsistent rows."""
    from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT

    def ratio(value):
        return f"{value:.2f}" + ("" if 1.0 / CONSISTENCY_RATIO_LIMIT <= value <= CONSISTENCY_RATIO_LIMIT else " !")

    nees = (f"; NEES in its 95 % band at {100 * nees_share:.1f} % of those epochs (mean of the {check_runs} check "
            "runs)" if nees_share is not None else "; NEES in band: needs --check-runs (LinCov has no single run)")
    lines = [f"consistency after {settle_days:g} d (error RMS from the budget, every source on / filter sigma RMS"
             f"{nees}):",
             "| spacecraft | position error RMS m | sigma RMS m | err/σ | velocity error RMS mm/s | sigma RMS mm/s "
             "| err/σ |", "|---|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(f"| {row['spacecraft']} | {row['error_rms_position_m']:.1f} | {row['sigma_rms_position_m']:.1f} | "
                     f"{ratio(row['position_error_to_sigma'])} | {1e3 * row['error_rms_velocity_m_s']:.3f} | "
                     f"{1e3 * row['sigma_rms_velocity_m_s']:.3f} | {ratio(row['velocity_error_to_sigma'])} |")
    bad = [row["spacecraft"] for row in rows if not row["consistent"]]
    if bad:
        lines.append(f"! inconsistent ({', '.join(bad)}): error RMS outside [{1 / CONSISTENCY_RATIO_LIMIT:.2f}, "
                     f"{CONSISTENCY_RATIO_LIMIT:g}]x the filter's sigma RMS (consistency.parquet: consistent)")
    return "\n".join(lines) + "\n"
