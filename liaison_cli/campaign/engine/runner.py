"""A scenario's Monte Carlo work in task order: the ordered layer over the one fan-out (backends.map_batches).
run_tasks_in_order is its one path, with a tqdm progress bar and Ctrl-C checks: a scenario's runs
(iter_outcomes, run_campaign) and the error budget's check runs (studies.error_budget) go through it."""

import numbers
from collections.abc import Callable, Iterator, Sequence
from contextlib import closing
from dataclasses import dataclass

from tqdm import tqdm

from liaison_cli.campaign.engine.noise_check import prepare_checked_problem
from liaison_cli.scenario.setup import Problem
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.campaign.engine.backends import LOCAL, Backend, map_batches
from liaison_cli.campaign.engine.worker import RunOutcome, RunTask, execute_run
from liaison_cli import interrupts
from liaison_cli.errors import LiaisonError


@dataclass(frozen=True, eq=False)
class CampaignResult:
    problem: Problem
    outcomes: tuple[RunOutcome, ...]

    @property
    def scenario(self) -> Scenario:
        return self.problem.scenario


def execute_run_batch(problem, runs):
    """Worker side: the outcomes of a batch of runs, given by their indexes (each outcome carries its own)."""
    interrupts.ignore_in_worker_process()
    return [execute_run(problem, RunTask(run)) for run in runs]


# A process pool costs about 1.5 s to start (spawn, imports, loading the compiled core). A run costs about
# 0.55 us per state element and epoch here, metrics and writing included (0.25 us of it the EKF). Measured on
# eml2_lunar with --jobs 2, 2 cores: 100 runs (5.5 million state-epochs) took 3.9 s in this process and 5.0 s
# with the pool; 150 runs (8.3 million) 5.4 s either way; 250 runs 6.8-7.8 s against 6.1-6.4 s. Below the
# break-even the runs stay in this process (joblib only: a dask cluster was asked for by name). The numbers
# are the same either way.
POOL_MIN_STATE_EPOCHS = 8_000_000
# A run that flies its own truth (model_error.truth_acceleration_sigma_m_s2) also propagates and measures it:
# `liaison run` of mt_eml2_lunar_range_and_rate, 120 runs, --jobs 1: 11.8-11.9 s with the force against
# 4.4-4.6 s without (1.2 s of each the process start), 3.2 times the work per run, so its state-epochs count
# 3.2 times against the break-even.
OWN_TRUTH_COST_FACTOR = 3.2


def stays_in_process(problem: Problem, n_runs: int, jobs: int, where: Backend) -> bool:
    work = n_runs * len(problem.times_s) * problem.filter.layout.n
    if problem.unforced is not None:
        work *= OWN_TRUTH_COST_FACTOR
    return where.name == "joblib" and (jobs == 1 or work < POOL_MIN_STATE_EPOCHS)


def iter_outcomes(problem: Problem, n_runs: int, jobs: int = 2, progress: bool = True,
                  description: str | None = None, where: Backend = LOCAL) -> Iterator[RunOutcome]:
    """Yield the outcomes of runs 0 … n_runs-1 in run order, as they finish (run_tasks_in_order).

    Memory is bounded by the fan-out's window (batches submitted and not yet consumed, a batch that finished
    ahead of its turn included) times the batch size, not by `n_runs`.
    """
    return run_tasks_in_order(execute_run_batch, problem, problem, n_runs, jobs, where, progress,
                              description or problem.scenario.name)


def run_tasks_in_order(fn: Callable, shared, problem: Problem, n_tasks: int, jobs: int, where: Backend,
                       progress: bool, description: str) -> Iterator:
    """Yield the results of tasks 0 … n_tasks-1 of `problem`'s Monte Carlo work in task order, as they finish.
    `fn(shared, tasks)` is a worker-side batch function: one result per task, in order, never raising for a
    task that fails (it reports it in its result).

    A small job stays in this process (stays_in_process), one task at a time. Otherwise task 0 is done here
    first (the compiled core is then loaded, or on a cold cache compiled once, not once per worker, and the
    workers find it in the cache) and the rest go through the fan-out in task order (in_task_order). The
    results are the same either way. A Ctrl-C that compiled code swallowed still stops the work."""
    bar = tqdm(total=n_tasks, desc=description, unit="run", disable=not progress, leave=False)
    here = range(n_tasks) if stays_in_process(problem, n_tasks, jobs, where) else range(min(n_tasks, 1))
    try:
        for task in here:
            (result,) = fn(shared, (task,))
            if interrupts.requested():
                raise KeyboardInterrupt
            yield result
            bar.update(1)
        for result in in_task_order(fn, shared, range(len(here), n_tasks), jobs, where):
            yield result
            bar.update(1)
    finally:
        bar.close()


def in_task_order(fn, shared, tasks: Sequence, jobs: int, where: Backend):
    """Yield the results of fn(shared, batch) for every task of `tasks` (a sequence: a range keeps memory
    bounded) in task order, through the one fan-out. A few tasks a batch keep the pipes busy without starving a
    progress bar. A Ctrl-C that compiled code swallowed still stops it; an error or Ctrl-C in the caller closes
    the fan-out at once (its workers stop), not when the traceback is freed. No tasks: no fan-out."""
    if not tasks:
        return
    chunk = max(1, min(8, len(tasks) // (4 * jobs)))
    batches = ((0, tuple(tasks[start : start + chunk])) for start in range(0, len(tasks), chunk))
    with closing(map_batches(fn, {0: shared}, batches, where, jobs, ordered=True)) as results:
        for batch in results:
            if interrupts.requested():
                raise KeyboardInterrupt
            yield from batch


def check_campaign_arguments(scenario, runs, jobs) -> None:
    """The Python API's arguments checked as the CLI checks its options: a validated Scenario (load_scenario's),
    whole run and job counts of at least 1 (None: the scenario's runs), one clear line otherwise."""
    if not isinstance(scenario, Scenario):
        raise LiaisonError(f"scenario: {type(scenario).__name__} given; allowed: a Scenario from "
                           "liaison_cli.scenario.schema.load_scenario (or apply_overrides)")
    for name, value, optional in (("runs", runs, True), ("jobs", jobs, False)):
        if optional and value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
            raise LiaisonError(f"{name}: {value!r}; allowed: a whole number, 1 or more")


def run_campaign(scenario: Scenario, runs: int | None = None, jobs: int = 2, progress: bool = True,
                 description: str | None = None, truth_cache: dict | None = None,
                 where: Backend = LOCAL) -> CampaignResult:
    """Run `runs` (default: the scenario's) Monte Carlo runs and keep every outcome in memory, ordered by
    run index (for studies of a few hundred runs; `liaison run` streams instead, see results.stream_campaign).

    The numbers of a run depend only on (scenario, seed, run index), never on `jobs` or the backend.
    `truth_cache`: see `scenario.setup.prepare_problem`; the default noise is LinCov-checked (engine.noise_check).
    """
    check_campaign_arguments(scenario, runs, jobs)
    problem = prepare_checked_problem(scenario, truth_cache)
    n_runs = scenario.monte_carlo.runs if runs is None else runs
    outcomes = tuple(iter_outcomes(problem, n_runs, jobs, progress, description, where))
    return CampaignResult(problem=problem, outcomes=outcomes)
