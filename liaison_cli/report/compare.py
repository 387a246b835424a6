"""Side-by-side scenario comparison (campaign.studies.compare computes it) as Markdown (001 Tables 6-7).
Formats only."""

import pandas as pd


def to_markdown(table: pd.DataFrame) -> str:
    lines = ["| scenario | S/C | links | runs ok | pos RMS m | [> 1 d] | vel RMS mm/s | [> 1 d] | pos err/σ | "
             "vel err/σ | NEES in band |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in table.itertuples():
        mark = "" if row.consistent_settled else " !"
        lines.append(f"| {row.scenario}{mark} | {row.spacecraft} | {row.links} | {row.runs_ok}/{row.runs} | "
                     f"{row.rms_position_m:.1f} | {row.rms_position_after_day1_m:.1f} | "
                     f"{1e3 * row.rms_velocity_m_s:.2f} | {1e3 * row.rms_velocity_after_day1_m_s:.2f} | "
                     f"{row.position_error_to_sigma_settled:.2f} | {row.velocity_error_to_sigma_settled:.2f} | "
                     f"{100 * row.frac_nees_in_band_settled:.0f} % |")
    return "\n".join(lines) + (
        "\n\nRMS per spacecraft averaged over runs, then averaged over the scenario's spacecraft. err/σ: after each "
        "scenario's filter.settle_days, the worst spacecraft's error RMS over its filter sigma RMS; NEES in band: "
        "share of those epochs whose NEES lies in its 95 % chi-square band. ! marks a scenario that fails the "
        "consistency verdict (analysis.consistency: the NEES test, whole state and each spacecraft's own, and the "
        "error/sigma ratio's 95 % interval against [0.67, 1.5]; compare.parquet: consistency_failed says which).\n")
