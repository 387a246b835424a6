"""002's result tables computed from a sweep (`liaison tables002`): DRMS p90 (Table 3 layout), clock RMS p90 (Table 4
layout), per-run metrics, consistency, and the runs of the histograms' grid cell. report.nrho002 formats and
draws them; campaign.studies.output writes them.

The sweep is any `liaison sweep` over scenarios whose estimator is batch, with the grid keys
`batch.span_days` and `measurement.interval_s`. Each grid point's scenario is classed from its own
content (kept in sweep.json): Earth-based when it has ground stations, RR when a link measures range-rate,
and its reading of 002's links: 'star' when every crosslink touches the main spacecraft (the receiver of the
first link, the Gateway: the shipped reading), 'mesh' when the anchors also range to each other (the second
reading, scenarios nrho_gateway_anchors_mesh*); for the Earth-based case, 'star' for the shipped station (a
10 deg mask, occulted) and 'visible' for an idealised always-visible one (nrho_earth_station_visible*), which
adds `earth_visible_{RR,NORR}_*` columns and `earth_{RR,NORR}_visible_ratio`. The DRMS and clock tables keep the star reading in their
original columns; a sweep that also holds mesh scenarios adds the mesh reading's columns and the ratio
mesh / star per cell (report.nrho002.format_readings prints them side by side).
Metrics, per run: DRMS = the mean over the constellation of each spacecraft's prediction RMS (002 Eq. 37-39,
the 3 h after the span); clock RMS = each anchor's synchronisation error RMS over the sync window and over
the prediction after it. Tables give the 90th percentile over the runs that finished ('ok').
Consistency (batch_consistency_table): per grid cell, case and spacecraft, the error RMS against the batch's own
sigma RMS after the settle time and the NEES-in-band share, from the sweep's per-run summary columns. A sweep
keeps no per-epoch series: the error and sigma curves of one cell come from `liaison run` on its scenario
(timeseries.parquet).
"""

import json
from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.analysis.metrics import campaign_error_to_sigma
from liaison_cli.errors import LiaisonError, UnreadableFileError
from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.scenario.loading import validate_scenario

NRHO_PERIOD_DAYS = 6.59  # 002 Table 1: T, the unit of the paper's time spans
SPAN_KEY = "batch.span_days"
INTERVAL_KEY = "measurement.interval_s"


class ReportError(LiaisonError):
    """A sweep folder that cannot give 002's tables."""


def _read(sweep_dir: Path):
    runs_path, meta_path = sweep_dir / "runs.parquet", sweep_dir / "sweep.json"
    for path in (runs_path, meta_path):
        if not path.exists():
            raise ReportError(f"{sweep_dir}: no {path.name} here; give a folder written by 'liaison sweep'")
    try:
        runs = pd.read_parquet(runs_path)
        meta = json.loads(meta_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise UnreadableFileError(f"{sweep_dir}: cannot read the sweep ({type(exc).__name__}: "
                                  f"{str(exc).splitlines()[0] if str(exc) else 'no detail'})") from None
    for key in (SPAN_KEY, INTERVAL_KEY):
        if key not in runs:
            raise ReportError(f"{sweep_dir}: the sweep's grid has no {key}; 002's tables need "
                              f"--grid {SPAN_KEY}=... --grid {INTERVAL_KEY}=...")
    if "rms_position_prediction_m" not in runs:
        raise ReportError(f"{sweep_dir}: no prediction DRMS in the runs; the scenarios need estimator: batch")
    return runs, meta


STAR, MESH = "star", "mesh"  # the two readings of 002's crosslinks
VISIBLE = "visible"  # the second reading of its Earth station: idealised, always visible
NO_HORIZON_DEG = -90.0


def _reading(scenario) -> str:
    """The shipped reading 'star' (its columns keep their names) or a second one. Autonomous: 'mesh' when some
    crosslink joins two spacecraft neither of which is the main one (the first link's receiver). Earth-based:
    'visible' when every station has no horizon (elevation_mask_deg -90) and no link is occulted (an idealised
    station that sees every spacecraft at every epoch)."""
    if scenario.ground_stations:
        visible = (all(station.elevation_mask_deg <= NO_HORIZON_DEG for station in scenario.ground_stations)
                   and not any(link.occultation for link in scenario.links))
        return VISIBLE if visible else STAR
    if not scenario.links:
        return STAR
    main = scenario.links[0].receiver
    return MESH if any(main not in (link.receiver, link.transponder) for link in scenario.links) else STAR


def _classes(meta) -> dict:
    """{scenario name: (case 'autonomous' | 'earth', measurements 'RR' | 'NORR', reading 'star' | 'mesh' |
    'visible')}
    from the scenario texts."""
    import yaml

    out = {}
    for name, text in meta["scenarios_yaml"].items():
        scenario = validate_scenario(yaml.safe_load(text), name)
        case = "earth" if scenario.ground_stations else "autonomous"
        # RR: some link measures a rate (a channel in m/s), whatever the observable is called.
        rr = any(channel.unit == "m/s" for link in scenario.links for name in link.observables
                 for channel in OBSERVABLES[name].channels)
        out[name] = (case, "RR" if rr else "NORR", _reading(scenario))
    return out


def per_run_metrics(sweep_dir) -> pd.DataFrame:
    """One row per (grid point, run): case, measurements, reading, span, interval, status, DRMS mean,
    per-spacecraft DRMS, and the clock RMS of each anchor (window / prediction, ns)."""
    sweep_dir = Path(sweep_dir)
    runs, meta = _read(sweep_dir)
    classes = _classes(meta)
    rows = []
    for (point, run), group in runs.groupby(["point", "run"], sort=True):
        first = group.iloc[0]
        case, measurements, reading = classes[first.scenario]
        ok = bool((group.status == "ok").all())
        row = {"point": int(point), "run": int(run), "scenario": first.scenario, "case": case,
               "measurements": measurements, "reading": reading, "span_days": float(first[SPAN_KEY]),
               "span_periods": float(first[SPAN_KEY]) / NRHO_PERIOD_DAYS, "interval_s": float(first[INTERVAL_KEY]),
               "status": "ok" if ok else "failed",
               "drms_mean_m": float(group.rms_position_prediction_m.mean()) if ok else np.nan}
        for item in group.itertuples():
            row[f"drms_{item.spacecraft}_m"] = float(item.rms_position_prediction_m) if ok else np.nan
            for which in ("window", "prediction"):
                value = getattr(item, f"clock_rms_{which}_ns", np.nan)
                if ok and value == value:  # not NaN: this spacecraft's clock is synchronised to the main one
                    row[f"clock_{which}_{item.spacecraft}_ns"] = float(value)
        rows.append(row)
    return pd.DataFrame(rows)


CONSISTENCY_COLUMNS = ("rms_position_settled_m", "sigma_position_settled_m", "rms_velocity_settled_m_s",
                       "sigma_velocity_settled_m_s", "frac_nees_in_band_settled")


def batch_consistency_table(sweep_dir) -> pd.DataFrame:
    """Per (span, interval, case, measurements, reading, spacecraft), over the runs that finished ('ok' for every
    spacecraft, as in the DRMS tables) and the epochs after the scenario's settle time (filter.settle_days):
    the error RMS and sigma RMS of position (m) and velocity (m/s) (root of the mean square over the runs),
    their ratios (analysis.metrics.campaign_error_to_sigma), the mean share of epochs whose NEES lies in its
    95 % band, and `consistent` / `consistency_failed`: the verdict of analysis.consistency (the NEES test and
    the two-sided ratio test). NaN (not consistent) for a sweep written before liaison recorded these columns."""
    sweep_dir = Path(sweep_dir)
    runs, meta = _read(sweep_dir)
    classes = _classes(meta)
    for column in CONSISTENCY_COLUMNS:
        if column not in runs:
            runs[column] = np.nan
    healthy = runs.groupby(["point", "run"]).status.transform(lambda status: (status == "ok").all())
    runs = runs.assign(run_ok=healthy)
    rows = []
    for (point, name), group in runs.groupby(["point", "spacecraft"], sort=True):
        first = group.iloc[0]
        case, measurements, reading = classes[first.scenario]
        ok = group[group.run_ok]
        row = {"point": int(point), "scenario": first.scenario, "case": case, "measurements": measurements,
               "reading": reading,
               "span_days": float(first[SPAN_KEY]), "span_periods": float(first[SPAN_KEY]) / NRHO_PERIOD_DAYS,
               "interval_s": float(first[INTERVAL_KEY]), "spacecraft": name, "runs": len(group), "runs_ok": len(ok)}
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            errors = ok[f"rms_{kind}_settled_{unit}"].dropna().to_numpy(dtype=float)
            sigmas = ok[f"sigma_{kind}_settled_{unit}"].dropna().to_numpy(dtype=float)
            row[f"error_rms_{kind}_{unit}"] = float(np.sqrt(np.mean(errors**2))) if errors.size else np.nan
            row[f"sigma_rms_{kind}_{unit}"] = float(np.sqrt(np.mean(sigmas**2))) if sigmas.size else np.nan
            row[f"{kind}_error_to_sigma"] = campaign_error_to_sigma(errors, sigmas)
        share = ok.frac_nees_in_band_settled.dropna()
        row["nees_in_band_share"] = float(share.mean()) if len(share) else np.nan
        verdict = campaign_verdict(ok)
        row["consistent"], row["consistency_failed"] = verdict["consistent_settled"], verdict["consistency_failed"]
        rows.append(row)
    return pd.DataFrame(rows)


def _p90(values) -> float:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.quantile(values, 0.9)) if values.size else np.nan


def _readings(metrics: pd.DataFrame) -> pd.Series:
    """Each row's reading ('star' for a per_run table written before readings were recorded)."""
    return metrics["reading"] if "reading" in metrics else pd.Series(STAR, index=metrics.index)


def _ratio(second: float, star: float) -> float:
    return second / star if star == star and second == second and star > 0 else np.nan


def drms_table(metrics: pd.DataFrame) -> pd.DataFrame:
    """Table 3 layout: one row per (span, interval), DRMS-mean p90 per (case, measurements) column, from the
    star reading. With a second reading's runs in the sweep (mesh, visible), per (case, measurements) that has
    them also `{case}_{reading}_{measurements}_drms_p90_m` / `_runs_ok` / `_runs` and
    `{case}_{measurements}_{reading}_ratio` (its p90 / the star reading's)."""
    metrics = metrics.assign(reading=_readings(metrics))
    rows = []
    for (span, interval), cell in metrics.groupby(["span_days", "interval_s"], sort=True):
        row = {"span_days": span, "span_periods": span / NRHO_PERIOD_DAYS, "interval_min": interval / 60.0}
        second_keys = []
        groups = sorted(cell.groupby(["case", "measurements", "reading"]),
                        key=lambda kv: (*kv[0][:2], kv[0][2] != STAR))
        for (case, measurements, reading), runs in groups:  # the star reading's columns first, as before
            ok = runs[runs.status == "ok"]
            key = f"{case}_{measurements}" if reading == STAR else f"{case}_{reading}_{measurements}"
            row[f"{key}_drms_p90_m"] = _p90(ok.drms_mean_m)
            row[f"{key}_runs_ok"] = len(ok)
            row[f"{key}_runs"] = len(runs)
            if reading != STAR:
                second_keys.append((case, measurements, reading))
        for case, measurements, reading in second_keys:
            row[f"{case}_{measurements}_{reading}_ratio"] = _ratio(
                row[f"{case}_{reading}_{measurements}_drms_p90_m"], row.get(f"{case}_{measurements}_drms_p90_m", np.nan))
        rows.append(row)
    return pd.DataFrame(rows)


def clock_rms_p90_table(metrics: pd.DataFrame) -> pd.DataFrame:
    """Table 4 layout: per (span, interval) and RR / NORR, the p90 over runs and anchors of the clock RMS over
    the 3 h sync window and over the 3 h prediction after it (autonomous cases only, star reading). With mesh
    runs in the sweep, also `mesh_runs_ok`, `mesh_clock_{window,prediction}_p90_ns` and
    `clock_{window,prediction}_mesh_ratio` (mesh p90 / star p90)."""
    own = metrics[(metrics.case == "autonomous") & (metrics.status == "ok")]
    own = own.assign(reading=_readings(own))
    has_mesh = bool((own.reading == MESH).any())
    rows = []
    for (span, interval, measurements), cell in own.groupby(["span_days", "interval_s", "measurements"], sort=True):
        row = {"span_days": span, "span_periods": span / NRHO_PERIOD_DAYS, "interval_min": interval / 60.0,
               "measurements": measurements}
        for reading, prefix in ((STAR, ""), (MESH, "mesh_")) if has_mesh else ((STAR, ""),):
            runs = cell[cell.reading == reading]
            row[f"{prefix}runs_ok"] = len(runs)
            for which in ("window", "prediction"):
                columns = [c for c in runs.columns if c.startswith(f"clock_{which}_")]
                row[f"{prefix}clock_{which}_p90_ns"] = _p90(runs[columns].to_numpy().ravel()) if columns else np.nan
        if has_mesh:
            for which in ("window", "prediction"):
                row[f"clock_{which}_mesh_ratio"] = _ratio(row[f"mesh_clock_{which}_p90_ns"],
                                                          row[f"clock_{which}_p90_ns"])
        rows.append(row)
    return pd.DataFrame(rows)


def histogram_cell(metrics: pd.DataFrame, span_days: float, interval_s: float) -> pd.DataFrame:
    """The runs the histograms show: one grid cell's runs that finished, shipped (star) reading."""
    return metrics[np.isclose(metrics.span_days, span_days) & np.isclose(metrics.interval_s, interval_s)
                   & (metrics.status == "ok") & (_readings(metrics) == STAR)]
