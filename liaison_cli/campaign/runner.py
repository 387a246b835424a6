"""Fan a scenario's Monte Carlo runs out over local processes (joblib), with a tqdm progress bar."""

from dataclasses import dataclass

from tqdm import tqdm

from liaison_cli.scenario.setup import Problem, prepare_problem
from liaison_cli.scenario.schema import Scenario
from liaison_cli.campaign.worker import RunOutcome, RunTask, execute_run
from liaison_cli import interrupts


@dataclass(frozen=True, eq=False)
class CampaignResult:
    problem: Problem
    outcomes: tuple[RunOutcome, ...]

    @property
    def scenario(self) -> Scenario:
        return self.problem.scenario


def _execute_batch(problem, tasks):
    interrupts.ignore_in_worker_process()
    return [execute_run(problem, task) for task in tasks]


# A process pool costs about 1.5 s to start (spawn, imports, loading the compiled core). A run costs about
# 0.55 us per state element and epoch here, metrics and writing included (0.25 us of it the EKF). Measured on
# eml2_lunar with --jobs 2, 2 cores: 100 runs (5.5 million state-epochs) took 3.9 s in this process and 5.0 s
# with the pool; 150 runs (8.3 million) 5.4 s either way; 250 runs 6.8-7.8 s against 6.1-6.4 s. Below the
# break-even the runs stay in this process. The numbers are the same either way.
POOL_MIN_STATE_EPOCHS = 8_000_000


def iter_outcomes(problem: Problem, n_runs: int, jobs: int = 2, progress: bool = True,
                  description: str | None = None):
    """Yield the outcomes of runs 0 … n_runs-1 in run order, as they finish.

    Work is dispatched a few batches ahead of what has been consumed (joblib's pre-dispatch), so the
    memory held is bounded by the batch size and the worker count, not by `n_runs`.
    """
    bar = tqdm(total=n_runs, desc=description or problem.scenario.name, unit="run", disable=not progress,
               leave=False)
    try:
        if jobs == 1 or n_runs * len(problem.times_s) * problem.filter.layout.n < POOL_MIN_STATE_EPOCHS:
            for run in range(n_runs):
                outcome = execute_run(problem, RunTask(run))
                if interrupts.requested():  # a Ctrl-C that compiled code swallowed still stops the campaign
                    raise KeyboardInterrupt
                yield outcome
                bar.update(1)
            return
        # Run 0 here first: the compiled core is then loaded (or, on a cold cache, compiled once, not once
        # per worker) before the pool starts, and the workers find it in the cache.
        yield execute_run(problem, RunTask(0))
        bar.update(1)
        # A few tasks per dispatch keeps the pipes busy without starving the bar.
        chunk = max(1, min(8, n_runs // (4 * jobs)))
        batches = (tuple(RunTask(i) for i in range(start, min(start + chunk, n_runs)))
                   for start in range(1, n_runs, chunk))
        from joblib import Parallel, delayed  # here: a run that stays in this process does not import it

        interrupts.shield_pool_workers()

        parallel = Parallel(n_jobs=jobs, return_as="generator", pre_dispatch="2*n_jobs")
        for batch in parallel(delayed(_execute_batch)(problem, b) for b in batches):
            if interrupts.requested():
                raise KeyboardInterrupt
            yield from batch
            bar.update(len(batch))
    finally:
        bar.close()


def run_campaign(scenario: Scenario, runs: int | None = None, jobs: int = 2, progress: bool = True,
                 description: str | None = None, truth_cache: dict | None = None) -> CampaignResult:
    """Run `runs` (default: the scenario's) Monte Carlo runs and keep every outcome in memory, ordered by
    run index (for studies of a few hundred runs; `liaison run` streams instead, see results.stream_campaign).

    The numbers of a run depend only on (scenario, seed, run index), never on `jobs`.
    `truth_cache`: see `prepare_problem`.
    """
    problem = prepare_problem(scenario, truth_cache)
    n_runs = scenario.monte_carlo.runs if runs is None else runs
    outcomes = tuple(iter_outcomes(problem, n_runs, jobs, progress, description))
    return CampaignResult(problem=problem, outcomes=outcomes)
