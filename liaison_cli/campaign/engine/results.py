"""Result tables of a campaign (Parquet, written atomically by liaison_cli.storage) with provenance.

`liaison run` writes every table from numpy columns and gets its summary back as rows (dicts), so its path
never imports pandas (about 0.3 s of a 1.5 s run). The table builders for studies across scenarios
(summary_table, timeseries_table, ...) return DataFrames and import pandas when called.
"""

import logging
import time
from numbers import Integral, Real
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from liaison_cli import __version__
from liaison_cli.analysis.metrics import chi2_quantile, nees_band
from liaison_cli.campaign.engine.backends import LOCAL, Backend
from liaison_cli.campaign.engine.runner import CampaignResult, iter_outcomes
from liaison_cli.campaign.engine.clock_record import clock_record_names
from liaison_cli.campaign.engine.noise_check import prepare_checked_problem
from liaison_cli.campaign.engine.worker import RunOutcome
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.scenario.setup import Problem
from liaison_cli.storage import ParquetStream, write_columns_atomic, write_text_atomic

if TYPE_CHECKING:
    import pandas as pd

log = logging.getLogger("liaison")  # -v shows its info lines (stage times) on stderr


def provenance(problem: Problem, n_runs: int, scenario_text: str, extra: dict | None = None) -> dict:
    scenario = problem.scenario
    meta = {
        "package": "liaison",
        "package_version": __version__,
        "arithmetic": arithmetic_provenance(),
        "scenario_name": scenario.name,
        "scenario_yaml": scenario_text,
        "scenario_effective": scenario.model_dump(mode="json"),
        "seed": scenario.monte_carlo.seed,
        "runs": n_runs,
        "sigma_m": problem.sigma_m,
        "settle_days": scenario.settle_days(),
        "seeding": "numpy SeedSequence(seed, spawn_key=(run,)); initial error drawn first, then noise; a random "
                   "truth acceleration from SeedSequence(seed, spawn_key=(run, 1))",
        "chosen_settings": chosen_settings(problem),
    }
    meta.update(extra or {})
    return meta


def chosen_settings(problem: Problem) -> dict:
    """What the tool chose for the scenario where its keys left it open: each estimated spacecraft's integrator
    substeps per interval (scenario.integration_steps: its source, and the estimated one-step error in m when
    chosen by accuracy) and the derived default process noise with its parts (scenario.default_noise)."""
    from liaison_cli.dynamics.constants import M_PER_LU

    steps = {name: {"substeps": choice.substeps, "source": choice.source,
                    "one_step_error_m": (None if choice.error_lu != choice.error_lu else choice.error_lu * M_PER_LU)}
             for name, choice in (problem.step_choices or {}).items()}
    noise = {name: {"psd_m2_s3": value.psd_m2_s3, "parts_m2_s3": dict(value.parts)}
             for name, value in (problem.default_noises or {}).items()}
    return {"integration": steps, "default_process_noise": noise}


def _summary_rows(problem: Problem, outcome: RunOutcome) -> list[dict]:
    per_sc = outcome.summary or [{"spacecraft": name} for name in problem.spacecraft]
    return [{"run": outcome.run, **row, "status": outcome.status, "reason": outcome.reason,
             "fail_time_s": outcome.fail_time_s} for row in per_sc]


def _summary_frame(rows: list[dict]) -> "pd.DataFrame":
    import pandas as pd

    return pd.DataFrame(rows).astype({"run": "int32"})


def summary_columns(rows: list[dict]) -> dict:
    """The summary rows as columns (name -> array), typed as pd.DataFrame(rows) would type them: keys in
    order of first appearance; a key a row lacks is NaN in a number column and None in a text column; all
    integers: int64 (run: int32); all booleans: bool."""
    names = list(dict.fromkeys(key for row in rows for key in row))
    columns = {}
    for name in names:
        values = [row.get(name) for row in rows]
        present = [v for v in values if v is not None]
        if name == "run":
            columns[name] = np.array(values, dtype=np.int32)
        elif present and all(isinstance(v, (bool, np.bool_)) for v in present) and len(present) == len(values):
            columns[name] = np.array(values, dtype=bool)
        elif present and all(isinstance(v, Integral) and not isinstance(v, (bool, np.bool_)) for v in present) \
                and len(present) == len(values):
            columns[name] = np.array(values, dtype=np.int64)
        elif all(isinstance(v, Real) and not isinstance(v, (bool, np.bool_)) for v in present):
            columns[name] = np.array([np.nan if v is None else v for v in values], dtype=float)
        else:
            columns[name] = np.array(values, dtype=object)
    return columns


# Per-run builders return columns (name -> 1-D array), not DataFrames: the writer stacks them per row
# group, which keeps the main process far ahead of the workers.
Columns = dict


SMOOTHED_NORMS = ("position_error_smoothed_m", "velocity_error_smoothed_m_s", "position_3sigma_smoothed_m",
                  "velocity_3sigma_smoothed_m_s")


def _timeseries_columns(problem: Problem, outcome: RunOutcome, float_dtype) -> Columns | None:
    """One row per (epoch, spacecraft) of one run: error norms, 3-sigma bounds, whole-state NEES."""
    if not outcome.norms:
        return None
    m, n_sc = outcome.norms["position_error_m"].shape
    columns = {
        "run": np.full(m * n_sc, outcome.run, dtype=np.int32),
        "t_s": np.repeat(problem.times_s, n_sc),
        "spacecraft": np.tile(np.array(problem.spacecraft, dtype=object), m),
    }
    epochs = absolute_epochs_tdb(problem)
    if epochs is not None:  # dated dynamics: each row's date too
        columns["epoch_tdb"] = np.repeat(epochs, n_sc)
    for key in ("position_error_m", "velocity_error_m_s", "position_3sigma_m", "velocity_3sigma_m_s", *SMOOTHED_NORMS):
        if key in outcome.norms:  # the smoothed ones only with filter.smoother: rts
            columns[key] = outcome.norms[key].reshape(-1).astype(float_dtype)
    columns["nees"] = np.repeat(outcome.nees, n_sc).astype(float_dtype)
    return columns


J2000_TDB = np.datetime64("2000-01-01T12:00:00", "ns")  # the TDB seconds of the dated model count from here


def absolute_epochs_tdb(problem: Problem, times_s=None):
    """(m,) datetime64[ns] on the TDB scale of each epoch of a dated scenario (dynamics.registry: dated), or of
    `times_s` (s from t0) when given, from its epoch's TDB seconds past J2000 (to the nanosecond); None for an
    undated model (the CRTBP has no date)."""
    if not problem.scenario.dynamics_descriptor().dated:
        return None
    seconds = float(problem.dynamics.epoch_tdb_s) + np.asarray(problem.times_s if times_s is None else times_s,
                                                               dtype=float)
    return J2000_TDB + np.round(seconds * 1e9).astype("timedelta64[ns]")


def _residuals_columns(problem: Problem, outcome: RunOutcome, float_dtype) -> Columns | None:
    """One row per (epoch, measurement channel) of one run: innovation (observed minus predicted) and its
    predicted standard deviation, in the channel's unit (m for range, m/s for range-rate, rad for angles);
    for the EKF both pre-fit, before the channel's own update. rejected: True where the residual gate
    (filter.residual_gate_sigma) refused the measurement, |innovation| > k innovation_std, so the filter did
    not update with it; its innovation is still recorded. Counting rejected per run and link gives the
    rejections per link (the summary's rejected_measurements is the run's total)."""
    if outcome.innovation_m is None:
        return None
    channels = problem.channel_labels
    m, n_channels = outcome.innovation_m[1:].shape
    return {
        "run": np.full(m * n_channels, outcome.run, dtype=np.int32),
        "t_s": np.repeat(problem.times_s[1:], n_channels),
        "link": np.tile(np.array([c[0] for c in channels], dtype=object), m),
        "observable": np.tile(np.array([c[1] for c in channels], dtype=object), m),
        "unit": np.tile(np.array([c[2] for c in channels], dtype=object), m),
        "innovation": outcome.innovation_m[1:].reshape(-1).astype(float_dtype),
        "innovation_std": outcome.innovation_std_m[1:].reshape(-1).astype(float_dtype),
        "rejected": _rejected(outcome, m, n_channels),
    }


# The two-sided 95 % band of one scalar's NIS, chi-square with 1 degree of freedom: (0.00098, 5.02).
NIS_BAND = (chi2_quantile(0.025, 1), chi2_quantile(0.975, 1))


def _link_columns(problem: Problem, outcome: RunOutcome, float_dtype) -> Columns | None:
    """One row per measurement channel of one run: its normalised innovation squared (NIS = innovation^2 /
    innovation_std^2, 1 on average and inside NIS_BAND 95 % of the time for a consistent filter) over the
    epochs after the settle time, leaving out the measurements the residual gate refused; the per-link view of
    consistency beside the NEES by direction."""
    if outcome.innovation_m is None:
        return None
    settled = problem.times_s >= problem.scenario.settle_days() * SECONDS_PER_DAY
    with np.errstate(invalid="ignore", divide="ignore"):
        nis = (outcome.innovation_m / outcome.innovation_std_m)[settled] ** 2
    finite = np.isfinite(nis)
    if outcome.rejected is not None:  # the gate's refused measurements did not update the filter: not its NIS
        finite &= ~outcome.rejected[settled]
    count = finite.sum(axis=0)
    inside = ((nis >= NIS_BAND[0]) & (nis <= NIS_BAND[1]) & finite).sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, np.where(finite, nis, 0.0).sum(axis=0) / np.maximum(count, 1), np.nan)
        share = np.where(count > 0, inside / np.maximum(count, 1), np.nan)
    channels = problem.channel_labels
    return {
        "run": np.full(len(channels), outcome.run, dtype=np.int32),
        "link": np.array([c[0] for c in channels], dtype=object),
        "observable": np.array([c[1] for c in channels], dtype=object),
        "innovations_settled": count.astype(np.int32),
        "mean_nis_settled": mean.astype(float_dtype),
        "frac_nis_in_band_settled": share.astype(float_dtype),
    }


def _rejected(outcome: RunOutcome, m: int, n_channels: int) -> np.ndarray:
    """The rejected flags of epochs 1.. as a column (all False for an outcome without them)."""
    if outcome.rejected is None:
        return np.zeros(m * n_channels, dtype=bool)
    return outcome.rejected[1:].reshape(-1)


def _bias_columns(problem: Problem, outcome: RunOutcome, float_dtype=None) -> Columns | None:
    """One row per link of one run: true range bias, the filter's final value and 1-sigma (m)."""
    if outcome.bias_true_m is None:
        return None
    n_links = len(problem.link_labels)
    return {
        "run": np.full(n_links, outcome.run, dtype=np.int64),
        "link": np.array(problem.link_labels, dtype=object),
        "status": np.full(n_links, outcome.status, dtype=object),
        "bias_true_m": np.asarray(outcome.bias_true_m, dtype=float),
        "bias_estimate_m": np.asarray(outcome.bias_estimate_m, dtype=float),
        "bias_sigma_m": np.asarray(outcome.bias_sigma_m, dtype=float),
        "treatment": np.full(n_links, problem.scenario.filter.bias, dtype=object),
    }


def _clock_columns(problem: Problem, outcome: RunOutcome, float_dtype) -> Columns | None:
    """One row per (epoch, clock) of one run: phase error and 1-sigma in ns, frequency error and 1-sigma
    (dimensionless, s/s); the estimated clocks, or a batch's clock_sync fits (worker.clock_record_names)."""
    if outcome.clock_error_s is None:
        return None
    m, n_clocks, _ = outcome.clock_error_s.shape
    return {
        "run": np.full(m * n_clocks, outcome.run, dtype=np.int32),
        "t_s": np.repeat(problem.times_s, n_clocks),
        "clock": np.tile(np.array(clock_record_names(problem), dtype=object), m),
        "phase_error_ns": (1e9 * outcome.clock_error_s[:, :, 0]).reshape(-1).astype(float_dtype),
        "phase_sigma_ns": (1e9 * outcome.clock_sigma_s[:, :, 0]).reshape(-1).astype(float_dtype),
        "frequency_error": outcome.clock_error_s[:, :, 1].reshape(-1).astype(float_dtype),
        "frequency_sigma": outcome.clock_sigma_s[:, :, 1].reshape(-1).astype(float_dtype),
    }


def _epoch_state_columns(problem: Problem, outcome: RunOutcome, float_dtype) -> Columns | None:
    """states.parquet (scenario output.epoch_states_runs): the worker's per-epoch state rows of one run
    (analysis.epoch_states; float_dtype applies to errors and sigmas, the estimate stays float64), with the run,
    and each row's TDB date in a dated scenario."""
    if outcome.epoch_states is None:
        return None
    states = outcome.epoch_states
    rows = len(states["t_s"])
    columns = {"run": np.full(rows, outcome.run, dtype=np.int32), "t_s": states["t_s"]}
    epochs = absolute_epochs_tdb(problem, states["t_s"])
    if epochs is not None:
        columns["epoch_tdb"] = epochs
    for name, values in states.items():
        if name != "t_s":
            columns[name] = values if values.dtype == object or name.endswith(("_km", "_km_s")) \
                else values.astype(float_dtype)
    return columns


# Per-run tables, streamed: file stem -> frame builder.
# Columns whose values repeat from row to row (dictionary-encoded in the streamed files).
REPEATING_COLUMNS = ("run", "t_s", "spacecraft", "link", "observable", "unit", "clock", "status", "treatment")
PER_RUN_TABLES = {"timeseries": _timeseries_columns, "residuals": _residuals_columns, "bias": _bias_columns,
                  "clocks": _clock_columns, "links": _link_columns}


def _concat(parts) -> "pd.DataFrame":
    import pandas as pd

    parts = [p for p in parts if p is not None]
    if not parts:
        return pd.DataFrame()
    return pd.DataFrame({key: np.concatenate([p[key] for p in parts]) for key in parts[0]})


def summary_table(result: CampaignResult) -> "pd.DataFrame":
    return _summary_frame([row for o in result.outcomes for row in _summary_rows(result.problem, o)])


def timeseries_table(result: CampaignResult, float_dtype="float32") -> "pd.DataFrame":
    return _concat(_timeseries_columns(result.problem, o, float_dtype) for o in result.outcomes)


def residuals_table(result: CampaignResult, float_dtype="float32") -> "pd.DataFrame":
    return _concat(_residuals_columns(result.problem, o, float_dtype) for o in result.outcomes)


def bias_table(result: CampaignResult) -> "pd.DataFrame":
    return _concat(_bias_columns(result.problem, o) for o in result.outcomes)


def clock_table(result: CampaignResult, float_dtype="float32") -> "pd.DataFrame":
    return _concat(_clock_columns(result.problem, o, float_dtype) for o in result.outcomes)


class NeesAccumulator:
    """Run-averaged NEES per epoch over the runs that finished 'ok', summed as they arrive."""

    def __init__(self, problem: Problem):
        self.problem = problem
        self.total = np.zeros(len(problem.times_s))
        self.runs = 0

    def add(self, outcome: RunOutcome) -> None:
        if outcome.status == "ok":
            self.total += outcome.nees
            self.runs += 1

    def columns(self) -> dict:
        """The mean NEES per epoch with its 95 % chi-square band (no columns when no run finished)."""
        if not self.runs:
            return {}
        state_size = self.problem.filter.n_nees  # the states the NEES covers (consider parameters excluded)
        lo, hi = nees_band(state_size, self.runs)
        mean = self.total / self.runs
        m = len(mean)
        return {"t_s": np.asarray(self.problem.times_s, dtype=float), "mean_nees": mean,
                "band_low": np.full(m, lo, dtype=float), "band_high": np.full(m, hi, dtype=float),
                "inside_band": (mean >= lo) & (mean <= hi), "runs": np.full(m, self.runs, dtype=np.int64),
                "state_size": np.full(m, state_size, dtype=np.int64)}

    def table(self) -> "pd.DataFrame":
        import pandas as pd

        return pd.DataFrame(self.columns())


def consistency_table(result: CampaignResult) -> "pd.DataFrame":
    """Run-averaged NEES per epoch over the runs that finished, with its 95 % chi-square band."""
    accumulator = NeesAccumulator(result.problem)
    for outcome in result.outcomes:
        accumulator.add(outcome)
    return accumulator.table()


def write_outcomes(problem: Problem, outcomes, n_runs: int, out_dir, scenario_text: str,
                   float_dtype="float32", flush_rows: int = 200_000) -> list[dict]:
    """Write every table of a campaign while its outcomes arrive (in run order), holding only the summary
    rows, a running NEES sum and a buffer of up to `flush_rows` rows per table. Returns the summary rows (one
    dict per run and spacecraft; summary.parquet holds them as summary_columns)."""
    out_dir = Path(out_dir)
    meta = provenance(problem, n_runs, scenario_text, {"float_dtype": float_dtype})
    tables = dict(PER_RUN_TABLES)
    if problem.scenario.output.epoch_states_runs:  # opt-in: no states.parquet otherwise
        tables["states"] = _epoch_state_columns
        meta = {**meta, "states_frame": states_frame(problem)}
    streams = {name: ParquetStream(out_dir / f"{name}.parquet", meta, flush_rows, REPEATING_COLUMNS) for name in tables}
    accumulator = NeesAccumulator(problem)
    rows: list[dict] = []
    try:
        for outcome in outcomes:
            rows.extend(_summary_rows(problem, outcome))
            accumulator.add(outcome)
            for name, build in tables.items():
                columns = build(problem, outcome, float_dtype)
                if columns is not None:
                    streams[name].append(columns)
        for stream in streams.values():
            stream.close()
    except BaseException:
        for stream in streams.values():
            stream.abort()
        raise
    write_columns_atomic(summary_columns(rows), out_dir / "summary.parquet", meta)
    write_columns_atomic(accumulator.columns(), out_dir / "consistency.parquet", meta)
    write_text_atomic(scenario_text, out_dir / "scenario.yaml")
    return rows


def states_frame(problem: Problem) -> str:
    """The frame of states.parquet's estimate and model-axis columns, in words (its provenance's states_frame)."""
    if problem.scenario.dynamics_descriptor().rotating_frame:
        return ("Earth-Moon rotating frame of the CRTBP: origin the barycentre, x from the Earth to the Moon, z along "
                "the orbit normal; 1 LU = 384,400 km")
    return "geocentric ICRF (GCRF), TDB epochs"


def write_campaign(result: CampaignResult, out_dir, scenario_text: str, float_dtype="float32") -> list[dict]:
    """Write summary / timeseries / residuals / links / consistency / bias / clocks Parquet and the scenario text of
    a campaign held in memory. Returns the summary rows."""
    return write_outcomes(result.problem, result.outcomes, len(result.outcomes), out_dir, scenario_text,
                          float_dtype)


def stream_campaign(scenario: Scenario, out_dir, scenario_text: str, runs: int | None = None, jobs: int = 2,
                    progress: bool = True, float_dtype="float32", where: Backend = LOCAL
                    ) -> tuple[Problem, list[dict]]:
    """Run a campaign and write its tables as runs finish: memory does not grow with the run count.
    Returns the problem and the summary rows."""
    started = time.perf_counter()
    problem = prepare_checked_problem(scenario)
    prepared = time.perf_counter()
    log.info("%s: truth, measurement plan and filter set up in %.2f s", scenario.name, prepared - started)
    n_runs = scenario.monte_carlo.runs if runs is None else runs
    if problem.observed is not None:  # measurements from a file: one run, no Monte Carlo
        n_runs = 1
    summary = write_outcomes(problem, iter_outcomes(problem, n_runs, jobs, progress, where=where), n_runs, out_dir,
                             scenario_text, float_dtype)
    log.info("%s: %d runs estimated and written in %.2f s (%d job(s))", scenario.name, n_runs,
             time.perf_counter() - prepared, jobs)
    return problem, summary


def summarise_campaign(scenario: Scenario, runs: int | None = None, jobs: int = 2, progress: bool = True,
                       description: str | None = None, truth_cache: dict | None = None,
                       where: Backend = LOCAL) -> tuple[Problem, "pd.DataFrame"]:
    """Run a campaign and keep only its summary rows (for tables across scenarios: compare, Table 3)."""
    started = time.perf_counter()
    problem = prepare_checked_problem(scenario, truth_cache)
    prepared = time.perf_counter()
    log.info("%s: truth, measurement plan and filter set up in %.2f s", scenario.name, prepared - started)
    n_runs = scenario.monte_carlo.runs if runs is None else runs
    rows = [row for outcome in iter_outcomes(problem, n_runs, jobs, progress, description, where)
            for row in _summary_rows(problem, outcome)]
    log.info("%s: %d runs estimated in %.2f s (%d job(s))", scenario.name, n_runs, time.perf_counter() - prepared,
             jobs)
    return problem, _summary_frame(rows)
