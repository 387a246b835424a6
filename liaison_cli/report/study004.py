"""004's study as a table and figures: per transmitter, the 3σ position and velocity histories of each
receiver pair (the analogue of 004 Figs. 6-9) and the pairs' DOP (the analogue of Fig. 2)."""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.report.study003 import pyplot, save_png


def format_table(summary: pd.DataFrame) -> str:
    lines = ["| transmitter | pair | steady 3σ pos km | steady 3σ vel cm/s | converged pos (d) | < 1 km from (d) | "
             "< 1 cm/s from (d) | epochs measured | median DOP | EKF runs ok | EKF inside 3σ pos | "
             "EKF error RMS last quarter km |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]

    def day(value):
        return "never" if not np.isfinite(value) else f"{value:.2f}"

    for r in summary.itertuples():
        converged = f"{day(r.convergence_days_position)} | {day(r.days_below_1km)} | {day(r.days_below_1cm_s)}"
        inside = "—" if not np.isfinite(r.ekf_inside_3sigma_position) else f"{100 * r.ekf_inside_3sigma_position:.1f} %"
        late = r.ekf_error_rms_last_quarter_position_m
        late = "—" if not np.isfinite(late) else f"{late / 1e3:.3f}"
        lines.append(f"| {r.transmitter} | {r.pair} | {r.steady_3sigma_position_m / 1e3:.3f} | "
                     f"{r.steady_3sigma_velocity_m_s * 1e2:.3f} | {converged} | {100 * r.measured_share:.0f} % | "
                     f"{r.median_dop:.2f} | {r.runs_ok}/{r.runs} | {inside} | {late} |")
    return "\n".join(lines) + "\n"


def draw_histories(history: pd.DataFrame, transmitter: str, out_dir: Path) -> Path:
    plt = pyplot()
    data = history[history.transmitter == transmitter]
    fig, axes = plt.subplots(3, 1, figsize=(9, 10), sharex=True)
    for pair, part in data.groupby("pair", sort=False):
        axes[0].semilogy(part.t_days, part.position_3sigma_m / 1e3, lw=1, label=pair)
        axes[1].semilogy(part.t_days, part.velocity_3sigma_m_s * 1e2, lw=1, label=pair)
        axes[2].semilogy(part.t_days[part.measured], part.dop[part.measured], ".", ms=1.5, label=pair)
    axes[0].set_ylabel("3σ position (km)")
    axes[1].set_ylabel("3σ velocity (cm/s)")
    axes[2].set_ylabel("DOP (m per m of path)")
    axes[2].set_xlabel("days")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{transmitter}: TDoA + FDoA, 3σ of the filter along the truth, and the pair's DOP")
    fig.tight_layout()
    path = save_png(fig, out_dir / f"{transmitter}_3sigma.png")
    plt.close(fig)
    return path
