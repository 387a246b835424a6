"""Side-by-side scenario comparison: RMS errors averaged over a scenario's spacecraft (001 Tables 6-7)."""

from pathlib import Path

import pandas as pd

from liaison_cli import __version__
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
    return row


def to_markdown(table: pd.DataFrame) -> str:
    lines = ["| scenario | S/C | links | runs ok | pos RMS m | [> 1 d] | vel RMS mm/s | [> 1 d] |",
             "|---|---|---|---|---|---|---|---|"]
    for row in table.itertuples():
        lines.append(f"| {row.scenario} | {row.spacecraft} | {row.links} | {row.runs_ok}/{row.runs} | "
                     f"{row.rms_position_m:.1f} | {row.rms_position_after_day1_m:.1f} | "
                     f"{1e3 * row.rms_velocity_m_s:.2f} | {1e3 * row.rms_velocity_after_day1_m_s:.2f} |")
    return "\n".join(lines) + "\n\nRMS per spacecraft averaged over runs, then averaged over the scenario's spacecraft.\n"


def write_compare(rows, summaries, texts, out_dir) -> tuple[pd.DataFrame, str]:
    out_dir = Path(out_dir)
    table = pd.DataFrame(rows)
    meta = {"package": "liaison", "package_version": __version__, "scenarios_yaml": texts}
    write_parquet_atomic(table, out_dir / "compare.parquet", meta)
    write_parquet_atomic(pd.concat(summaries, ignore_index=True), out_dir / "summary.parquet", meta)
    markdown = to_markdown(table)
    write_text_atomic(markdown, out_dir / "compare.md")
    return table, markdown
