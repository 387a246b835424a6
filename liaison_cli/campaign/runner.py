"""Fan a scenario's Monte Carlo runs out over local processes (joblib), with a tqdm progress bar."""

from dataclasses import dataclass

from joblib import Parallel, delayed
from tqdm import tqdm

from liaison_cli.scenario.setup import Problem, prepare_problem
from liaison_cli.scenario.schema import Scenario
from liaison_cli.campaign.worker import RunOutcome, RunTask, execute_run


@dataclass(frozen=True, eq=False)
class CampaignResult:
    problem: Problem
    outcomes: tuple[RunOutcome, ...]

    @property
    def scenario(self) -> Scenario:
        return self.problem.scenario


def _execute_batch(problem, tasks):
    return [execute_run(problem, task) for task in tasks]


def run_campaign(scenario: Scenario, runs: int | None = None, jobs: int = 2, progress: bool = True,
                 description: str | None = None, truth_cache: dict | None = None) -> CampaignResult:
    """Run `runs` (default: the scenario's) Monte Carlo runs; outcomes come back ordered by run index.

    The numbers of a run depend only on (scenario, seed, run index), never on `jobs`.
    `truth_cache`: see `prepare_problem`.
    """
    problem = prepare_problem(scenario, truth_cache)
    n_runs = scenario.monte_carlo.runs if runs is None else runs
    tasks = [RunTask(i) for i in range(n_runs)]
    bar = tqdm(total=n_runs, desc=description or scenario.name, unit="run", disable=not progress, leave=False)
    outcomes: list[RunOutcome] = []
    if jobs == 1 or n_runs == 1:
        for task in tasks:
            outcomes.append(execute_run(problem, task))
            bar.update(1)
    else:
        # A few tasks per dispatch keeps the pipes busy without starving the bar.
        chunk = max(1, min(8, n_runs // (4 * jobs)))
        batches = [tasks[i : i + chunk] for i in range(0, n_runs, chunk)]
        parallel = Parallel(n_jobs=jobs, return_as="generator")
        for batch in parallel(delayed(_execute_batch)(problem, b) for b in batches):
            outcomes.extend(batch)
            bar.update(len(batch))
    bar.close()
    outcomes.sort(key=lambda o: o.run)
    return CampaignResult(problem=problem, outcomes=tuple(outcomes))
