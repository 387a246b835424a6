"""Side-by-side scenario comparison: RMS errors averaged over a scenario's spacecraft (001 Tables 6-7)."""

import math
from pathlib import Path

import pandas as pd

from liaison_cli import __version__
from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.analysis.metrics import campaign_error_to_sigma
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.storage import write_parquet_atomic, write_text_atomic

METRICS = ("rms_position_m", "rms_velocity_m_s", "rms_position_after_day1_m", "rms_velocity_after_day1_m_s")


def compare_rows(scenario, summary: pd.DataFrame) -> dict:
    """Mean over runs that finished, then over spacecraft; run counts kept beside."""
    ok = summary[summary.status == "ok"]
    per_sc = ok.groupby("spacecraft")[list(METRICS)].mean()
    runs = summary.drop_duplicates("run")
    row = {"scenario": scenario.name, "description": scenario.description,
           "spacecraft": len(scenario.spacecraft), "links": len(scenario.links),
           "topology": scenario.topology.kind if scenario.topology else "links",
           "runs": len(runs), "runs_ok": int((runs.status == "ok").sum())}
    for metric in METRICS:
        row[metric] = float(per_sc[metric].mean()) if len(per_sc) else float("nan")
    row.update(consistency_of(ok))
    return row


def consistency_of(ok: pd.DataFrame) -> dict:
    """The worst spacecraft's error/sigma ratio after the settle time (position and velocity, each the campaign
    ratio of analysis.metrics; worst: the farthest from 1 either way), the mean share of epochs with the NEES
    in its 95 % band, and the verdict of every spacecraft (analysis.consistency)."""
    ratios = {"position": [], "velocity": []}
    for _, group in ok.groupby("spacecraft"):
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            ratios[kind].append(campaign_error_to_sigma(group[f"rms_{kind}_settled_{unit}"],
                                                        group[f"sigma_{kind}_settled_{unit}"]))
    # The worst: farthest from 1 either way (|ln r|), as the verdict is two-sided; NaN wins (max() over NaN would
    # depend on the order).
    worst = {kind: (float("nan") if any(v != v for v in values) else max(values, key=lambda r: abs(math.log(r))
                                                                          if r > 0 else math.inf))
             if values else float("nan") for kind, values in ratios.items()}
    return {"position_error_to_sigma_settled": worst["position"],
            "velocity_error_to_sigma_settled": worst["velocity"],
            "frac_nees_in_band_settled": float(ok.frac_nees_in_band_settled.mean()) if len(ok) else float("nan"),
            **_verdict_of_every_spacecraft(ok)}


def _verdict_of_every_spacecraft(ok: pd.DataFrame) -> dict:
    """consistent_settled when every spacecraft passes analysis.consistency.campaign_verdict; what failed, by name."""
    failed = []
    for name, group in ok.groupby("spacecraft"):
        verdict = campaign_verdict(group)
        if not verdict["consistent_settled"]:
            failed.append(f"{name}: {verdict['consistency_failed']}")
    return {"consistent_settled": not failed and len(ok) > 0, "consistency_failed": " | ".join(failed)}


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


def write_compare(rows, summaries, texts, out_dir) -> tuple[pd.DataFrame, str]:
    out_dir = Path(out_dir)
    table = pd.DataFrame(rows)
    meta = {"package": "liaison", "package_version": __version__, "arithmetic": arithmetic_provenance(),
            "scenarios_yaml": texts}
    write_parquet_atomic(table, out_dir / "compare.parquet", meta)
    write_parquet_atomic(pd.concat(summaries, ignore_index=True), out_dir / "summary.parquet", meta)
    markdown = to_markdown(table)
    write_text_atomic(markdown, out_dir / "compare.md")
    return table, markdown
