"""Resumable sweeps: scenarios x a full-factorial grid of overrides x Monte Carlo runs.

Every (grid point, run index) is a task whose id is the hash of the point's effective scenario plus the
run index, so the id is stable across invocations. A JSON-lines manifest (one header line, then one line
per finished task) is the single source of truth: a killed sweep started again with the same command
skips every task already in it, and the Parquet tables are always rebuilt from it in task order, so an
interrupted-and-resumed sweep writes the same bytes as an uninterrupted one, whatever the backend.

A task whose line says 'error' (an exception in the worker: no result) is run again on resume and its new
line appended; the last line of a task wins. 'diverged' is a result (the filter's health check tripped) and
is kept.

Manifest format (the header's "format"), and the migration rule:
- 2 (this version): a task may have several lines (a retried error); the last one counts.
- 1 (liaison before issue 24): the same header and record fields, each task once. Read as is and resumed
  in place: its header line is kept and new lines are appended as format 2, which a format-1 reader also
  reads (it too keeps the last line of a task).
A format newer than MANIFEST_FORMAT, or a header without one, is refused in one line (exit 2) naming the
file, and the file is left untouched. A new format must state here how each older one is read.
"""

import errno
import hashlib
import itertools
import warnings
from contextlib import contextmanager
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli import __version__, core_source_hash
from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT, campaign_error_to_sigma
from liaison_cli.campaign.backends import check_backend, map_batches
from liaison_cli.scenario.setup import prepare_problem
from liaison_cli.storage import fsync_folder, naming, write_parquet_atomic, write_text_atomic
from liaison_cli.scenario.schema import Scenario, apply_overrides
from liaison_cli.campaign.worker import RunTask, execute_run
from liaison_cli.errors import LiaisonError
from liaison_cli.interrupts import ignore_in_worker_process

MANIFEST_FORMAT = 2
READABLE_MANIFEST_FORMATS = (1, 2)  # see the module docstring: older formats are read and resumed in place
METRICS = ("rms_position_m", "rms_velocity_m_s", "rms_position_after_day1_m", "rms_velocity_after_day1_m_s")
# Present only for some estimators / scenarios (a batch's prediction, clock synchronisation): summarised
# in the curve when a grid point has them.
OPTIONAL_METRICS = ("rms_position_prediction_m", "rms_velocity_prediction_m_s", "clock_rms_window_ns",
                    "clock_rms_prediction_ns")
SIGMA_KEY = "noise.sigma_m"


class SweepError(LiaisonError):
    """The output folder holds a different sweep, or the sweep definition is inconsistent."""


class SweepInterrupted(LiaisonError):
    """Ctrl-C: what finished is in the manifest; the same command resumes."""

    exit_code = 130


@contextmanager
def sweep_lock(out_dir: Path):
    """One sweep at a time per folder: an exclusive lock on `.<folder>.lock` beside it (outside the folder,
    so `--overwrite` cannot remove it from under another sweep). A busy folder is one line, exit 2."""
    import fcntl

    out_dir = Path(out_dir)
    # Keyed on the folder, not on how its path is spelled: through a symlink or `..` it is the same lock.
    try:
        real = out_dir.resolve()
    except RuntimeError:  # Python < 3.13 reports a symlink loop so, not as an OSError
        raise OSError(errno.ELOOP, os.strerror(errno.ELOOP), str(out_dir)) from None
    real.parent.mkdir(parents=True, exist_ok=True)
    handle = open(real.parent / f".{real.name}.lock", "a")
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        handle.close()
        raise SweepError(f"{out_dir}: another liaison sweep is writing into this folder; wait for it to finish "
                         "or choose --output") from None
    try:
        yield
    finally:
        fcntl.flock(handle.fileno(), fcntl.LOCK_UN)
        handle.close()


def scenario_hash(scenario: Scenario) -> str:
    """Hash of the effective (validated, defaults filled) configuration, not of the YAML text."""
    canonical = json.dumps(scenario.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class SweepPoint:
    index: int
    scenario_name: str
    base_hash: str
    overrides: tuple[tuple[str, object], ...]
    point_hash: str
    sigma_m: float
    spacecraft: tuple[str, ...]
    scenario: Scenario = field(compare=False, repr=False)

    def header_entry(self) -> dict:
        return {
            "point": self.index,
            "scenario": self.scenario_name,
            "base_hash": self.base_hash,
            "overrides": [[k, v] for k, v in self.overrides],
            "point_hash": self.point_hash,
        }


@dataclass(frozen=True)
class SweepTask:
    task_id: str
    point: int
    run: int


@dataclass(frozen=True, eq=False)
class SweepPlan:
    name: str
    grid: tuple[tuple[str, tuple], ...]
    runs: int
    points: tuple[SweepPoint, ...]
    base_texts: dict

    @property
    def tasks(self) -> list[SweepTask]:
        return [SweepTask(f"{p.point_hash}/{r}", p.index, r) for p in self.points for r in range(self.runs)]

    def key(self) -> str:
        """A short digest of the header: the same sweep definition (any run count) has the same key."""
        return hashlib.sha256(json.dumps(self.header(), sort_keys=True).encode()).hexdigest()[:12]

    def header(self) -> dict:
        return {
            "kind": "header",
            "format": MANIFEST_FORMAT,
            "sweep": self.name,
            "core_hash": core_source_hash(),
            "points": [p.header_entry() for p in self.points],
        }


def plan_sweep(bases: list[tuple[Scenario, str, str]], grid: list[tuple[str, list]], runs: int,
               name: str) -> SweepPlan:
    """bases: (scenario, yaml text, source path); grid: [(dotted key, values)] -> full factorial plan.

    Setting `noise.sigma_m` on a scenario whose sigma comes from a link budget replaces that budget.
    """
    keys = [key for key, _ in grid]
    repeated = sorted({k for k in keys if keys.count(k) > 1})
    if repeated:
        raise SweepError(f"--grid {repeated[0]}: given more than once (also by --sigma for {SIGMA_KEY})")
    names = [scenario.name for scenario, _, _ in bases]
    if len(set(names)) != len(names):
        raise SweepError(f"scenario name {max(names, key=names.count)!r} given more than once")
    points, seen = [], {}
    for scenario, _, source in bases:
        base_hash = scenario_hash(scenario)
        for values in itertools.product(*[vals for _, vals in grid]):
            overrides = tuple(zip(keys, values))
            effective = dict(overrides)
            if SIGMA_KEY in effective:
                # The budget stays when the carrier still derives range-rate / LOS sigmas from it.
                dropped = {"noise.ranging_method": None}
                if scenario.noise.carrier is None:
                    dropped["noise.link_budget"] = None
                effective = {**dropped, **effective}
            shown = ", ".join(f"{k}={v}" for k, v in overrides)
            point = apply_overrides(scenario, effective, f"{source} with --grid {shown}") if overrides else scenario
            point_hash = scenario_hash(point)
            if point_hash in seen:
                raise SweepError(f"{source}: grid point {shown} gives the same scenario as {seen[point_hash]}")
            seen[point_hash] = shown or source
            points.append(
                SweepPoint(len(points), scenario.name, base_hash, overrides, point_hash,
                           point.noise.resolved_sigma_m(), tuple(point.spacecraft_names()), point)
            )
    return SweepPlan(name, tuple((k, tuple(v)) for k, v in grid), runs, tuple(points),
                     {scenario.name: text for scenario, text, _ in bases})


# --- manifest -----------------------------------------------------------------------------------------


def read_manifest(path: Path) -> tuple[dict | None, dict, int]:
    """(header, {task_id: record}, byte length of the valid prefix). A torn last line (killed mid-write)
    is ignored and later truncated away."""
    if not path.exists():
        return None, {}, 0
    data = path.read_bytes()
    header, records, valid = None, {}, 0
    position = 0
    for line in data.splitlines(keepends=True):
        position += len(line)
        if not line.endswith(b"\n"):
            break  # torn last line (killed mid-write): cut away on the next open
        try:
            entry = json.loads(line)
        except json.JSONDecodeError:
            if header is None:
                break
            valid = position
            continue  # a corrupt complete line is skipped, not the records after it (its task is recomputed)
        if header is None:
            header = entry
        elif isinstance(entry, dict) and "task" in entry:
            records[entry["task"]] = entry
        valid = position
    return header, records, valid


class Manifest:
    """Append-only JSON lines: flushed and fsynced after every finished batch."""

    def __init__(self, path: Path, header: dict):
        self.path = path
        existing, self.records, valid = read_manifest(path)
        if existing is not None:
            _check_header(path, existing, header)  # before the file is opened for writing: refused, untouched
        self.handle = open(path, "ab")
        self.handle.truncate(valid)
        if existing is None:
            self._write([header])
            fsync_folder(path.parent)  # the new file's name, not only its bytes

    def _write(self, entries):
        with naming(self.path):  # a full disk here names the manifest; a torn last line is dropped on resume
            self.handle.write(b"".join(json.dumps(e, sort_keys=True).encode() + b"\n" for e in entries))
            self.handle.flush()
            os.fsync(self.handle.fileno())

    def append(self, records: list[dict]) -> None:
        self._write(records)
        for record in records:
            self.records[record["task"]] = record

    def close(self):
        with naming(self.path):
            self.handle.close()

    def done(self) -> set[str]:
        """Tasks with a result: every recorded task but those whose last line is an 'error' (run again)."""
        return {task for task, record in self.records.items() if record.get("status") != "error"}


def _check_header(path: Path, old, new: dict) -> None:
    """The manifest at `path` can be resumed by the sweep whose header is `new` (see the format rule)."""
    version = old.get("format") if isinstance(old, dict) else None
    if isinstance(version, int) and not isinstance(version, bool) and version > MANIFEST_FORMAT:
        raise SweepError(f"{path}: manifest format {version} is newer than this liaison ({__version__}) reads "
                         f"(up to {MANIFEST_FORMAT}); resume it with the liaison that wrote it, or pass --overwrite "
                         "to start again or --output to choose another folder")
    if version not in READABLE_MANIFEST_FORMATS or old.get("kind") != "header":
        raise SweepError(_header_mismatch(path, old, new))
    if {**old, "format": new["format"]} != new:
        raise SweepError(_header_mismatch(path, old, new))


def _header_mismatch(path, old, new) -> str:
    if not isinstance(old, dict) or old.get("format") not in READABLE_MANIFEST_FORMATS or old.get("kind") != "header":
        what = "a manifest this version cannot read"
    elif old.get("core_hash") != new["core_hash"]:
        what = "results of a different numeric core (liaison was changed or upgraded since)"
    elif old.get("sweep") != new["sweep"]:
        what = f"sweep {old.get('sweep')!r}"
    else:
        what = "a sweep over other scenarios or grid points"
    return (f"{path}: the folder holds {what}; resume needs the same scenarios and grid. "
            "Pass --overwrite to start again or --output to choose another folder")


# --- execution ----------------------------------------------------------------------------------------


def execute_batch(problem, tasks: list[SweepTask]) -> list[dict]:
    """Worker side: one JSON-ready record per task. Never raises (execute_run reports failures)."""
    ignore_in_worker_process()
    records = []
    for task in tasks:
        outcome = execute_run(problem, RunTask(task.run))
        with np.errstate(all="ignore"):
            mean_nees = float(np.nanmean(outcome.nees)) if outcome.nees is not None else float("nan")
        records.append(
            {
                "task": task.task_id,
                "point": task.point,
                "run": task.run,
                "status": outcome.status,
                "reason": outcome.reason,
                "fail_time_s": outcome.fail_time_s,
                "mean_nees": mean_nees,
                "rows": outcome.summary,
            }
        )
    return records


def _batches(pending: list[SweepTask], batch_runs: int) -> list[tuple[int, list[SweepTask]]]:
    batches = []
    for point, group in itertools.groupby(pending, key=lambda t: t.point):
        group = list(group)
        batches += [(point, group[i : i + batch_runs]) for i in range(0, len(group), batch_runs)]
    return batches


def _catch_sigint(flag: list):
    """SIGINT appends to `flag` instead of raising (main thread only; elsewhere nothing changes)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGINT, lambda signum, frame: flag.append(signum))


def _restore_sigint(previous) -> None:
    import signal

    if previous is not None:
        signal.signal(signal.SIGINT, previous)


@dataclass(frozen=True, eq=False)
class SweepResult:
    runs_table: pd.DataFrame
    curve_table: pd.DataFrame
    computed: int
    reused: int
    paths: dict


def run_sweep(plan: SweepPlan, out_dir: Path, backend: str = "joblib", jobs: int = 2,
              scheduler: str | None = None, progress: bool = True, batch_runs: int = 5,
              connect_timeout_s: float = 20.0) -> SweepResult:
    """Run every task not yet in `out_dir/manifest.jsonl`, then (re)write the Parquet tables."""
    from tqdm import tqdm

    check_backend(backend, scheduler)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    manifest = Manifest(out_dir / "manifest.jsonl", plan.header())
    try:
        tasks = plan.tasks
        done = manifest.done()
        pending = [t for t in tasks if t.task_id not in done]
        reused = len(tasks) - len(pending)
        truth_cache: dict = {}
        needed = sorted({t.point for t in pending})
        problems = {i: prepare_problem(plan.points[i].scenario, truth_cache) for i in needed}
        del truth_cache
        bar = tqdm(total=len(tasks), initial=reused, desc=f"sweep {plan.name}", unit="run",
                   disable=not progress, smoothing=0.1)
        # Ctrl-C only raises a flag, checked between batches: a KeyboardInterrupt raised inside compiled code
        # (numba's callbacks) can be swallowed, and a batch cut in half would be recomputed anyway.
        if pending and backend == "joblib" and jobs > 1:
            # One run here first (its result is recomputed by its batch): the compiled core is loaded, or on
            # a cold cache compiled once instead of once per worker, before the pool starts.
            execute_run(problems[pending[0].point], RunTask(pending[0].run))
        interrupted = []
        previous = _catch_sigint(interrupted)
        results = map_batches(execute_batch, problems, _batches(pending, batch_runs), backend, jobs, scheduler,
                              connect_timeout_s)
        try:
            for records in results:
                manifest.append(records)
                bar.update(len(records))
                if interrupted:
                    raise KeyboardInterrupt
        except KeyboardInterrupt:
            bar.close()
            with warnings.catch_warnings():  # joblib's note on cancelled tasks: they are simply not saved
                warnings.simplefilter("ignore")
                getattr(results, "close", lambda: None)()
            saved = len(manifest.done() & {t.task_id for t in tasks})
            raise SweepInterrupted(f"interrupted: {saved} of {len(tasks)} tasks saved in {manifest.path}; rerun the "
                                   "same command to resume") from None
        finally:
            _restore_sigint(previous)
        bar.close()
        _, records, _ = read_manifest(manifest.path)  # tables come from what is on disk, nothing else
    except KeyboardInterrupt:  # before the batches started (setting up, first compilation, starting workers)
        saved = len(manifest.done() & {t.task_id for t in plan.tasks})
        raise SweepInterrupted(f"interrupted: {saved} of {len(plan.tasks)} tasks saved in {manifest.path}; rerun "
                               "the same command to resume") from None
    finally:
        manifest.close()
    runs_table = build_runs_table(plan, records)
    curve_table = build_curve_table(plan, runs_table)
    paths = write_sweep_tables(plan, out_dir, runs_table, curve_table)
    return SweepResult(runs_table, curve_table, computed=len(pending), reused=reused, paths=paths)


# --- tables -------------------------------------------------------------------------------------------


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
    out["consistent_settled"] = bool(out["position_error_to_sigma_settled"] <= CONSISTENCY_RATIO_LIMIT
                                     and out["velocity_error_to_sigma_settled"] <= CONSISTENCY_RATIO_LIMIT)
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
    """Provenance of a sweep; deliberately free of backend, worker count and timestamps."""
    return {
        "package": "liaison",
        "package_version": __version__,
        "core_hash": core_source_hash(),
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
