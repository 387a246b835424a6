"""The machine-readable summaries `--json` prints instead of the text (run, sweep, compare, budget, errors,
validate, observability, design, tune, table3, geometry, study003, study004, tables002); docs/json-output.md documents every key. Formats only: the numbers are those the text shows,
from the campaign's summary rows, the sweep's curve table, the link file and the error budget. Units are in
the key names (`_m`, `_m_s`, `_db`, ...), shares are fractions in [0, 1], and a number that does not exist
(NaN: no healthy run) is null."""

import json
import math

from liaison_cli import __version__
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.report.run_text import mean, ok_values, quantile

# Per-spacecraft means over the runs that finished 'ok' (the columns `liaison run` prints).
RUN_MEANS = ("rms_position_m", "rms_position_after_day1_m", "rms_velocity_m_s", "rms_velocity_after_day1_m_s",
             "frac_in_2sigma_after_day1", "frac_in_3sigma_after_day1", "frac_nees_in_band_settled",
             "frac_nees_above_band_settled", "rms_position_smoothed_m", "rms_velocity_smoothed_m_s")
# Batch scenarios: mean and 90th percentile over the runs that finished 'ok'.
RUN_BATCH_STATISTICS = ("rms_position_prediction_m", "clock_rms_window_ns", "clock_rms_prediction_ns")


def to_json_text(document: dict) -> str:
    """Indented JSON with NaN and infinities as null (JSON has no NaN)."""
    return json.dumps(_finite(document), indent=2, allow_nan=False)


def _finite(value):
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {str(k): _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # a numpy scalar
        return _finite(value.item())
    return value


def _header(command: str) -> dict:
    return {"command": command, "liaison_version": __version__}


def _computed_header(command: str) -> dict:
    """The header of a document whose numbers come from runs: also what the arithmetic ran on (its last
    digits depend on it; liaison_cli.provenance). `budget` and `validate` compute nothing of that kind."""
    return {**_header(command), "arithmetic": arithmetic_provenance()}


def _verdict(summary: list[dict], name: str) -> dict:
    """The spacecraft's campaign verdict as the run text prints it (analysis.consistency.campaign_verdict):
    consistent_settled, consistency_failed and the ratios' interval half-widths (None when not finite)."""
    from liaison_cli.analysis.consistency import campaign_verdict
    from liaison_cli.report.run_text import CONSISTENCY_COLUMNS

    if not ok_values(summary, name, "rms_position_settled_m"):
        return {"consistent_settled": None, "consistency_failed": "no healthy run, or no epoch after the settle time"}
    out = campaign_verdict({column: ok_values(summary, name, column) for column in CONSISTENCY_COLUMNS})
    widths = {f"{kind}_error_to_sigma_halfwidth": out[f"{kind}_error_to_sigma_halfwidth"]
              for kind in ("position", "velocity")}
    return {"consistent_settled": bool(out["consistent_settled"]), "consistency_failed": out["consistency_failed"],
            **{key: (value if math.isfinite(value) else None) for key, value in widths.items()}}


def run_document(config, scenario_file, problem, summary: list[dict], out_dir) -> dict:
    """`liaison run --json`: the campaign's settings, run counts and per-spacecraft figures."""
    from liaison_cli.report.run_text import campaign_ratio

    runs = {}
    for row in summary:
        runs.setdefault(row["run"], row)
    spacecraft = {}
    for name in problem.spacecraft:
        figures = {}
        for column in RUN_MEANS:
            values = ok_values(summary, name, column)
            if any(column in row for row in summary):
                figures[column] = mean(values)
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            figures[f"{kind}_error_to_sigma_settled"] = campaign_ratio(summary, name, kind, unit)
        figures.update(_verdict(summary, name))
        for column in RUN_BATCH_STATISTICS:
            if any(column in row for row in summary):
                values = ok_values(summary, name, column)
                figures[f"{column}_mean"] = mean(values)
                figures[f"{column}_p90"] = quantile(values, 0.9) if values else math.nan
        spacecraft[name] = figures
    return {**_computed_header("run"), "scenario": config.name, "scenario_file": str(scenario_file),
            "output": str(out_dir), "estimator": "batch" if config.batch is not None else "ekf",
            "seed": config.monte_carlo.seed,
            "sigma_m": problem.sigma_m, "links": len(config.links), "settle_days": config.settle_days(),
            "runs": len(runs), "runs_ok": sum(row["status"] == "ok" for row in runs.values()),
            "failed_runs": [{"run": int(r["run"]), "status": r["status"], "reason": r.get("reason", "")}
                            for r in runs.values() if r["status"] != "ok"],
            "spacecraft": spacecraft}


def sweep_document(name: str, out_dir, grid_keys, curve, tasks: int, computed: int, reused: int) -> dict:
    """`liaison sweep --json`: the sweep's counts and one object per row of curve.parquet."""
    return {**_computed_header("sweep"), "name": name, "output": str(out_dir), "grid_keys": list(grid_keys),
            "points": int(curve.point.nunique()), "tasks": tasks, "computed": computed, "reused": reused,
            "spacecraft_runs_excluded": int(curve.runs_excluded.sum()),
            "curve": curve.to_dict("records")}


def compare_document(table, out_dir) -> dict:
    """`liaison compare --json`: one object per scenario (the rows of compare.parquet)."""
    return {**_computed_header("compare"), "output": str(out_dir), "scenarios": table.to_dict("records")}


def budget_document(link_file, link, expected=None, sweep_dir=None) -> dict:
    """`liaison budget --json`: the legs, each method's ranging sigma, the carrier's sigmas, the dual one-way
    receiver's bounds, and (with --sweep) the expected OD errors."""
    document = {**_header("budget"), "link_file": str(link_file), "legs": None, "ranging_sigma_m": None,
                "correlator_integration_s": None, "carrier": None, "dual_one_way": None, "sweep": None,
                "expected_errors": None}
    if link.dual_one_way is not None:
        document["dual_one_way"] = link.dual_one_way.receiver().sigmas()
    if link.link_budget is None:
        return document
    document["legs"] = {}
    for leg_name in ("uplink", "downlink"):
        leg = getattr(link.link_budget, leg_name).leg()
        document["legs"][leg_name] = {
            "distance_km": leg.distance_km, "data_rate_bps": leg.data_rate_bps,
            "free_space_loss_db": leg.free_space_loss_db, "c_over_n0_dbhz": leg.c_over_n0_dbhz,
            "es_over_n0_db": leg.es_over_n0_db, "margin_db": leg.margin_db}
    document["ranging_sigma_m"] = link.sigma_by_method()
    document["correlator_integration_s"] = link.correlator_integration_s
    if link.carrier is not None:
        carrier = link.carrier.sigmas(link.link_budget)
        document["carrier"] = {"range_rate_sigma_m_s": carrier["range_rate_sigma_m_s"],
                               "los_path_sigma_m": carrier["los_path_sigma_m"],
                               "uplink_loop_snr": carrier["uplink_loop_snr"],
                               "downlink_loop_snr": carrier["downlink_loop_snr"],
                               "doppler_count_s": link.carrier.doppler_count_s}
    if expected is not None:
        document["sweep"] = str(sweep_dir)
        document["expected_errors"] = expected.to_dict("records")
    return document


def errors_document(scenario, out_dir, rows_all, rows_late, checks) -> dict:
    """`liaison errors --json`: each part's share of the mean-square error (all epochs after t0 and after
    day 1) and the Monte Carlo check's ratios."""
    return {**_computed_header("errors"), "scenario": scenario.name, "duration_days": scenario.duration_days,
            "output": str(out_dir), "shares": rows_all, "shares_after_day1": rows_late,
            "monte_carlo_check": checks}


def validate_document(results: list[tuple]) -> dict:
    """`liaison validate --json`: results = [(path, error message or None)]."""
    files = [{"path": str(path), "ok": error is None, "error": error} for path, error in results]
    return {**_header("validate"), "files": files, "ok": sum(f["ok"] for f in files),
            "failed": sum(not f["ok"] for f in files)}


def observability_document(summary: dict, out_dir) -> dict:
    """`liaison observability --json`: the summary the text prints (observability.json), with the result folder."""
    return {**_computed_header("observability"), "output": str(out_dir), **summary}


# The candidates' columns `liaison design --json` lists (campaign.studies.design; NaN / empty: not verified).
DESIGN_COLUMNS = ("rank", "candidate", "family", "period_days", "phase", "score_m", "converge_days",
                  "range_condition_number", "pareto", "mc_score_m", "mc_over_lincov", "mc_runs_ok", "mc_consistent")


def design_document(scenario_name: str, open_spacecraft: str, family: str, objective: str, table, out_dir,
                    rank_rho: float, condition_rho: float, factors=(), converge_below_m=None) -> dict:
    """`liaison design --json`: every scored candidate in rank order (DESIGN_COLUMNS, its `factors`' values under
    `factors`), the ones not scored with their reason, and the two rank correlations."""
    scored = table[table.score_m.notna()]
    failed = table[table.score_m.isna()]
    candidates = [{**{column: row.get(column) for column in DESIGN_COLUMNS},
                   "factors": {factor: row.get(factor) for factor in factors}} for row in scored.to_dict("records")]
    for row in candidates:  # not verified: null, not an empty string
        for column in ("mc_runs_ok", "mc_consistent"):
            row[column] = row[column] or None
    return {**_computed_header("design"), "scenario": scenario_name, "open": open_spacecraft, "family": family,
            "objective": objective, "converge_below_m": converge_below_m, "output": str(out_dir),
            "candidates": candidates,
            "not_scored": [{"candidate": int(row["candidate"]), "period_days": row["period_days"],
                            "phase": row["phase"], "factors": {factor: row.get(factor) for factor in factors},
                            "error": row["error"]} for row in failed.to_dict("records")],
            "spearman_lincov_monte_carlo": rank_rho, "spearman_condition_lincov": condition_rho}


def tune_document(frame, rule: str, table_path) -> dict:
    """`liaison tune --json`: the rule in words, the files written, and the tune table's rows (the Parquet's
    columns), one per scenario, setting (the shipped noise or a rung) and spacecraft."""
    return {**_computed_header("tune"), "rule": rule, "table": str(table_path),
            "parquet": str(table_path.with_suffix(".parquet")), "rows": frame.to_dict("records")}


def study_document(command: str, output, tables: dict, **extra) -> dict:
    """`liaison table3 | geometry | study003 | study004 | tables002 --json`: the result folder and, under
    `tables`, each named table's rows as the Parquet of that name holds them (the per-epoch histories and
    per-run rows stay in their Parquet files), plus the command's own keys (`extra`)."""
    return {**_computed_header(command), "output": str(output), **extra,
            "tables": {stem: frame.to_dict("records") for stem, frame in tables.items()}}


def export_document(done: dict, out_dir) -> dict:
    """`liaison export --json`: the run exported, the folder and files written, the frame, and how far the
    recomputed run's position errors are from the stored ones."""
    return {**_computed_header("export"), "scenario": done["scenario"], "run": done["run"], "output": str(out_dir),
            "files": list(done["files"]), "epochs": done["epochs"], "ref_frame": done["ref_frame"],
            "center_name": done["center_name"], "time_system": done["time_system"],
            "stored_difference_m": done["stored_difference_m"], "not_in_tdm": list(done["skipped"])}


def scenarios_document(rows: list, templates: list) -> dict:
    """`liaison scenarios --json`: every shipped scenario and link file (name, kind, description) and the
    templates' names."""
    return {**_header("scenarios"), "shipped": rows, "templates": list(templates)}


def orbit_families_document(families: dict, cached: list) -> dict:
    """`liaison orbits list --json`: each family's name and description, and the cached tables' paths."""
    return {**_header("orbits list"), "families": families, "cached_tables": cached}


def orbit_family_document(family: str, frame) -> dict:
    """`liaison orbits show --json`: the family table's rows (orbits.family_table: the initial state in LU and LU/TU,
    period, Jacobi constant, stability index, amplitudes, perilune, closure)."""
    return {**_computed_header("orbits show"), "family": family,
            "members": [row._asdict() for row in frame.itertuples()]}
