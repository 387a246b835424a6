"""A sweep's tables, always rebuilt from its manifest in task order (so an interrupted-and-resumed sweep writes
the same bytes as an uninterrupted one, whatever the backend): one row per run and spacecraft (runs.parquet),
the curve of summary statistics per grid point and spacecraft (curve.parquet), and their provenance."""

import json
from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli import RESULT_PACKAGES, __version__, core_source_hash
from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.analysis.metrics import campaign_error_to_sigma
from liaison_cli.campaign.sweep.plan import SweepPlan, SweepPoint
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.storage import write_parquet_atomic, write_text_atomic

METRICS = ("rms_position_m", "rms_velocity_m_s", "rms_position_after_day1_m", "rms_velocity_after_day1_m_s")
# Present only for some estimators / scenarios (a batch's prediction, clock synchronisation): summarised
# in the curve when a grid point has them.
OPTIONAL_METRICS = ("rms_position_prediction_m", "rms_velocity_prediction_m_s", "clock_rms_window_ns",
                    "clock_rms_prediction_ns")


def _grid_columns(plan: SweepPlan, point: SweepPoint) -> dict:
    values = dict(point.overrides)
    return {key: values[key] for key, _ in plan.grid}


def build_runs_table(plan: SweepPlan, records: dict) -> pd.DataFrame:
    """One row per (grid point, run, spacecraft), in task order."""
    rows = []
    for task in plan.tasks:
        record = records[task.task_id]
        point = plan.points[task.point]
        per_sc = record["rows"] or [{"spacecraft": name} for name in point.spacecraft]
        for sc_row in per_sc:
            row = {
                "point": point.index,
                "scenario": point.scenario_name,
                **_grid_columns(plan, point),
                "sigma_m": point.sigma_m,
                "run": task.run,
                "spacecraft": sc_row["spacecraft"],
                "status": record["status"],
                "reason": record["reason"],
                "fail_time_s": record["fail_time_s"],
                "mean_nees": record["mean_nees"],
            }
            for key, value in sc_row.items():
                if key != "spacecraft":
                    row[key] = value
            rows.append(row)
    table = pd.DataFrame(rows)
    for metric in METRICS:
        if metric not in table:
            table[metric] = np.nan
    return table.astype({"point": "int32", "run": "int32"})


def _curve_consistency(ok: pd.DataFrame) -> dict:
    """A grid point's consistency for one spacecraft after the settle time: the campaign error/sigma ratios
    (analysis.metrics.campaign_error_to_sigma), the mean share of NEES in band, and the verdict. NaN (and not
    consistent) for a manifest written before these columns existed."""
    out = {}
    for kind, unit in (("position", "m"), ("velocity", "m_s")):
        columns = (f"rms_{kind}_settled_{unit}", f"sigma_{kind}_settled_{unit}")
        present = all(c in ok for c in columns) and len(ok)
        out[f"{kind}_error_to_sigma_settled"] = (campaign_error_to_sigma(ok[columns[0]].dropna(), ok[columns[1]].dropna())
                                                 if present else float("nan"))
    share = ok["frac_nees_in_band_settled"] if "frac_nees_in_band_settled" in ok else pd.Series(dtype=float)
    out["frac_nees_in_band_settled_mean"] = float(share.mean()) if len(share) else float("nan")
    verdict = campaign_verdict(ok)  # the NEES test and the ratio's interval (analysis.consistency)
    out["consistent_settled"], out["consistency_failed"] = verdict["consistent_settled"], verdict["consistency_failed"]
    return out


def build_curve_table(plan: SweepPlan, runs_table: pd.DataFrame) -> pd.DataFrame:
    """Per (grid point, spacecraft): mean, median and 10/90 % quantiles of each RMS metric over the runs
    that finished; `runs_excluded` counts the diverged / failed runs left out; the point's consistency
    after the settle time (_curve_consistency)."""
    rows = []
    for point in plan.points:
        mine = runs_table[runs_table.point == point.index]
        for name in point.spacecraft:
            sc = mine[mine.spacecraft == name]
            ok = sc[sc.status == "ok"]
            row = {
                "point": point.index,
                "scenario": point.scenario_name,
                **_grid_columns(plan, point),
                "sigma_m": point.sigma_m,
                "spacecraft": name,
                "runs": len(sc),
                "runs_ok": len(ok),
                "runs_excluded": len(sc) - len(ok),
            }
            for metric in METRICS + tuple(m for m in OPTIONAL_METRICS if m in ok):
                values = ok[metric].to_numpy(dtype=float)
                empty = values.size == 0
                row[f"{metric}_mean"] = np.nan if empty else float(values.mean())
                row[f"{metric}_median"] = np.nan if empty else float(np.median(values))
                row[f"{metric}_p10"] = np.nan if empty else float(np.quantile(values, 0.1))
                row[f"{metric}_p90"] = np.nan if empty else float(np.quantile(values, 0.9))
            row.update(_curve_consistency(ok))
            rows.append(row)
    return pd.DataFrame(rows).astype({"point": "int32"})


def sweep_metadata(plan: SweepPlan) -> dict:
    """Provenance of a sweep; deliberately free of backend, worker count and timestamps. Its arithmetic is this
    process's (liaison_cli.provenance): the local pool's workers share it, a dask cluster's may not."""
    return {
        "package": "liaison",
        "package_version": __version__,
        "arithmetic": arithmetic_provenance(),
        "core_hash": core_source_hash(RESULT_PACKAGES),
        "sweep": plan.name,
        "runs_per_point": plan.runs,
        "grid": [[key, list(values)] for key, values in plan.grid],
        "scenarios_yaml": plan.base_texts,
        "seeds": {p.scenario_name: p.scenario.monte_carlo.seed for p in plan.points},
        "points": [p.header_entry() for p in plan.points],
        "seeding": "numpy SeedSequence(scenario seed, spawn_key=(run,)) at every grid point, so grid points "
                   "share random numbers (common random numbers: smoother curves in the swept value)",
    }


def write_sweep_tables(plan: SweepPlan, out_dir: Path, runs_table, curve_table) -> dict:
    meta = sweep_metadata(plan)
    paths = {"runs": out_dir / "runs.parquet", "curve": out_dir / "curve.parquet",
             "manifest": out_dir / "manifest.jsonl"}
    write_parquet_atomic(runs_table, paths["runs"], meta)
    write_parquet_atomic(curve_table, paths["curve"], meta)
    write_text_atomic(json.dumps(meta, indent=2, sort_keys=True) + "\n", out_dir / "sweep.json")
    return paths
