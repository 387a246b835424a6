"""Running a sweep (run_sweep): the tasks of a plan not yet in its manifest, through the one fan-out
(engine.backends.map_batches) on joblib or dask, then its tables rewritten from the manifest. The other parts of
a sweep are beside it in campaign.sweep: plan (grid points, tasks, the manifest header), manifest (what is done,
and the folder lock), tables (the runs and curve tables) and worker (the workers' side).
"""

import itertools
import warnings
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from liaison_cli.campaign.engine.backends import Backend, can_fork, check_backend, map_batches, start_workers
from liaison_cli.campaign.sweep.manifest import Manifest, read_manifest
from liaison_cli.campaign.sweep.plan import SweepInterrupted, SweepPlan, SweepTask
from liaison_cli.campaign.sweep.tables import build_curve_table, build_runs_table, write_sweep_tables
from liaison_cli.campaign.sweep.worker import execute_sweep_batch  # the workers import that light module, not this one
from liaison_cli import interrupts
from liaison_cli.campaign.engine.noise_check import prepare_checked_problem


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
    check_backend(backend, scheduler)
    where = Backend(backend, scheduler, connect_timeout_s)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    manifest = Manifest(out_dir / "manifest.jsonl", plan.header())
    try:
        done = manifest.done()
        pending = [t for t in plan.tasks if t.task_id not in done]
        _run_pending(plan, pending, manifest, where, jobs, progress, batch_runs)
        _, records, _ = read_manifest(manifest.path)  # tables come from what is on disk, nothing else
    except (KeyboardInterrupt, Exception) as exc:  # also before the batches started (setting up, first
        # compilation, starting workers); an Exception only when a Ctrl-C caused it (numba's, when one lands
        # while it compiles)
        if not interrupts.caused_by_interrupt(exc):  # a KeyboardInterrupt is one
            raise
        saved = len(manifest.done_on_disk() & {t.task_id for t in plan.tasks})
        raise SweepInterrupted(f"interrupted: {saved} of {len(plan.tasks)} tasks saved in {manifest.path}; rerun "
                               "the same command to resume") from None
    finally:
        manifest.close()
    runs_table = build_runs_table(plan, records)
    curve_table = build_curve_table(plan, runs_table)
    paths = write_sweep_tables(plan, out_dir, runs_table, curve_table)
    return SweepResult(runs_table, curve_table, computed=len(pending), reused=len(plan.tasks) - len(pending),
                       paths=paths)


class _Problems(dict):
    """The grid points' problems, each prepared when first asked for (as its first batch is submitted: the
    batches come point by point, so a point's truth is propagated while the workers compute the earlier
    points' runs, not before any run starts). The truth cache that points of one scenario share is dropped
    once every point of `points` is prepared."""

    def __init__(self, plan: SweepPlan, points):
        super().__init__()
        self.plan, self.left, self.truth_cache = plan, set(points), {}

    def __missing__(self, point: int):
        problem = self[point] = prepare_checked_problem(self.plan.points[point].scenario, self.truth_cache)
        self.left.discard(point)
        if not self.left:
            self.truth_cache = {}
        return problem

    def prepare_all(self) -> "_Problems":
        for point in sorted(self.left):
            self[point]  # noqa: B018 - prepares it
        return self


def _run_pending(plan: SweepPlan, pending: list[SweepTask], manifest: Manifest, where: Backend, jobs: int,
                 progress: bool, batch_runs: int) -> None:
    """Fan the pending tasks out; each finished batch is appended to the manifest before the next is taken.

    Local workers are forked once this process has run the first task (its compiled core loaded, or compiled
    once, not once per worker), and the problems are prepared as their batches go out (_Problems). Where this
    platform cannot fork, loky's workers are started first, while the first problem is prepared (issue 37).
    dask gets every problem first (they are scattered to its workers)."""
    from tqdm import tqdm

    pooled = bool(pending) and not (where.name == "joblib" and jobs == 1)
    if pooled and not can_fork():
        start_workers(where, jobs, execute_sweep_batch.__module__)
    problems = _Problems(plan, {t.point for t in pending})
    if where.name == "dask":
        problems.prepare_all()
    if pooled:  # its record is kept: the run is the same wherever it is computed
        manifest.append(run_first_here(problems[pending[0].point], pending[0]))
        pending = pending[1:]
    bar = tqdm(total=len(plan.tasks), initial=len(plan.tasks) - len(pending), desc=f"sweep {plan.name}", unit="run",
               disable=not progress, smoothing=0.1)
    # Ctrl-C only raises a flag, checked between batches: a KeyboardInterrupt raised inside compiled code
    # (numba's callbacks) can be swallowed, and a batch cut in half would be recomputed anyway.
    interrupted = []
    previous = _catch_sigint(interrupted)
    results = map_batches(execute_sweep_batch, problems, _batches(pending, batch_runs), where, jobs, fork=True)
    try:
        for records in results:
            manifest.append(records)
            bar.update(len(records))
            if interrupted:
                raise KeyboardInterrupt
    except KeyboardInterrupt:
        with warnings.catch_warnings():  # a note on cancelled tasks: they are simply not saved
            warnings.simplefilter("ignore")
            getattr(results, "close", lambda: None)()
        raise
    finally:
        bar.close()
        _restore_sigint(previous)


def run_first_here(problem, task: SweepTask) -> list[dict]:
    """The first task's record, computed in this process before any worker starts (see _run_pending)."""
    return execute_sweep_batch(problem, [task])
