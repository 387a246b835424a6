"""The error budget of a scenario: LinCov parts by source (estimation.lincov) and Monte Carlo checks.

Sources (names a user may select):
- initial: the initial estimate error (initial_error; clock a-priori spread);
- noise: measurement noise;
- process: truth process noise (the clocks' random walks; the CRTBP truth has none);
- bias: unmodelled or considered range biases, one part per link (random part; the constant part is
  deterministic and goes with the mismatches);
- measurement_model: the filter's measurement-model error (light time in the truth, geometric filter);
- dynamics_model: the filter's dynamics error (its RK4 substeps against the truth propagator; clock drifts;
  in dated dynamics the bodies its model leaves out);
- cr (dated dynamics with model_error.cr_sigma or ephemeris.cr_error_sigma) and moon_gm (model_error.
  moon_gm_sigma): the per-run error of the filter's C_R or lunar GM, a random part, the change of the
  dynamics-model mean when that parameter is off by one sigma (linear in it). The fixed model_error biases
  are in the filter's model itself, so dynamics_model carries them.
Random parts add in variance; deterministic parts add as mean errors, whose square (cross terms included)
enters the second moment once. Units out: m^2 and (m/s)^2 per spacecraft, summed over the three axes.
The LinCov half (`error_budget`, `consistency`) is campaign.studies.lincov_budget's, re-exported here.
Consistency (`consistency`): after the settle time, the budget's total error RMS against the filter's own sigma
RMS, per spacecraft; the Monte Carlo check adds the runs' share of epochs with the NEES in its band.
The budget is the ungated EKF's: LinCov ignores filter.residual_gate_sigma (estimation.lincov says why);
the Monte Carlo check runs the scenario's EKF, gate included.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli import interrupts
from liaison_cli.analysis.metrics import fraction, nees_run_band
from liaison_cli.campaign.engine.backends import LOCAL, Backend
from liaison_cli.campaign.engine.runner import run_tasks_in_order
from liaison_cli.campaign.engine.worker import draw_run_inputs, true_empirical_accelerations
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.interrupts import caused_by_interrupt
from liaison_cli.estimation.estimators import estimate
from liaison_cli.estimation.lincov import filter_model_along_truth
from liaison_cli.scenario.setup import Problem
from liaison_cli.campaign.studies.lincov_budget import (  # the LinCov half, re-exported for the studies and tests
    Budget,
    BudgetError,
    _filter_truth,
    _parameter_truths,
    _per_spacecraft,
    consistency,
    error_budget,
)

SOURCES = ("initial", "noise", "process", "bias", "measurement_model", "dynamics_model")


def select_sources(text: str | None) -> tuple[str, ...]:
    """'initial,noise' -> ('initial', 'noise'); None -> every source. Unknown names: BudgetError."""
    if text is None:
        return SOURCES
    names = tuple(part.strip() for part in text.split(",") if part.strip())
    unknown = [name for name in names if name not in SOURCES]
    if unknown or not names:
        raise BudgetError(f"--sources {text!r}: unknown source {unknown[0] if unknown else '(none)'!r}; "
                          f"allowed: {', '.join(SOURCES)}")
    return names


def part_of(name: str) -> str:
    """The source a budget part belongs to ('bias EML2->Lunar' -> 'bias', 'bias_mean' -> 'bias')."""
    if name.startswith("bias"):
        return "bias"
    if name == "deterministic_cross":
        return "measurement_model"  # cross terms among deterministic means: shown with the model mismatch
    return name


def shares(budget: Budget, after_s: float = 0.0) -> list[dict]:
    """Per spacecraft and part: the share of the mean-square error over epochs after `after_s` (> t0)."""
    use = (budget.times_s > 0.0) & (budget.times_s >= after_s)
    rows = []
    for i, name in enumerate(budget.spacecraft):
        total = budget.total[use, i].mean(axis=0)
        for part, values in budget.parts.items():
            mean = values[use, i].mean(axis=0)
            rows.append({"spacecraft": name, "part": part, "source": part_of(part),
                         "position_share": float(mean[0] / total[0]), "velocity_share": float(mean[1] / total[1]),
                         "position_rms_m": float(np.sqrt(max(mean[0], 0.0))),
                         "velocity_rms_m_s": float(np.sqrt(max(mean[1], 0.0)))})
        rows.append({"spacecraft": name, "part": "total", "source": "total", "position_share": 1.0,
                     "velocity_share": 1.0, "position_rms_m": float(np.sqrt(total[0])),
                     "velocity_rms_m_s": float(np.sqrt(total[1]))})
    return rows


# --- Monte Carlo checks ---------------------------------------------------------------------------------


def _source_inputs(problem: Problem, run: int, model_y: np.ndarray, sources) -> tuple:
    """x0_hat, y_obs, truth for one run with only `sources` switched on (the same random draws as a full run:
    draw_run_inputs, split into its pieces)."""
    full = draw_run_inputs(problem, run)
    truth = full.truth
    bias_channel = np.zeros(problem.measurements_true.shape)
    for c, ch in enumerate(problem.channels):
        if ch.takes_range_bias:
            bias_channel[1:, c] = full.bias_lu[ch.link]
    noise = full.y_obs - problem.measurements_true - bias_channel  # no clocks in a checked scenario
    x0 = truth[0].copy()
    if "initial" in sources:
        x0[: problem.truth.shape[1]] = full.x0_hat[: problem.truth.shape[1]]
    y = (problem.measurements_true if "measurement_model" in sources else model_y).copy()
    if "noise" in sources:
        y += noise
    if "bias" in sources:
        y += bias_channel
    if problem.n_bias:  # bias states start at 0 in the filter, whatever the truth
        x0[problem.bias_state_start : problem.bias_state_start + problem.n_bias] = 0.0
    # A dynamics-parameter state: the check's filter flies problem.filter's parameters (model_error's fixed
    # errors, no per-run draw, which only the budget's "cr" part carries), so its truth is the correction back
    # from those, and the filter starts it at its a-priori mean, 0.
    truth = truth.copy()
    for start, value in _parameter_truths(problem):
        truth[:, start] = value
        x0[start] = 0.0
    # Empirical accelerations start at their a-priori mean, 0, as in a run (LinCov's truth holds 0 there and
    # counts the truth's acceleration in the dynamics-model part).
    for start, _ in true_empirical_accelerations(problem):
        x0[start : start + 3] = 0.0
    return x0, y, truth


@dataclass(frozen=True, eq=False)
class CheckInputs:
    """What every check worker shares (sent once per batch; on dask, scattered once): the problem, the filter
    model's measurements along the truth (model_y), the source groups (tuples of source names), the runs per
    group and the settle time from which the NEES is judged. Task t is run t % runs of group t // runs."""

    problem: Problem
    model_y: np.ndarray
    groups: tuple
    runs: int
    settle_s: float


@dataclass(frozen=True, eq=False)
class CheckRun:
    """One check run (a work unit's result; a worker never raises): group index, run index, squared error (m,
    n_sc, 2) in m^2 and (m/s)^2, the share of epochs from settle_s on with the NEES in its 95 % band, and the
    reason it failed ('' when it did not; then squared is None)."""

    group: int
    run: int
    squared: np.ndarray | None
    nees_in_band: float
    reason: str = ""


def run_check_batch(inputs: CheckInputs, tasks) -> list[CheckRun]:
    """Worker side: task indexes (CheckInputs); each, the EKF run with only its group's sources on."""
    interrupts.ignore_in_worker_process()
    return [_check_run(inputs, *divmod(task, inputs.runs)) for task in tasks]


def _check_run(inputs: CheckInputs, group: int, run: int) -> CheckRun:
    problem = inputs.problem
    try:
        x0, y, truth = _source_inputs(problem, run, inputs.model_y, inputs.groups[group])
        history = estimate(problem.scenario.estimator, problem.filter, x0, y, truth)
        if not history.ok:
            return CheckRun(group, run, None, float("nan"), f"diverged ({history.reason})")
        low, high = nees_run_band(problem.filter.n_nees)
        nees = np.asarray(history.nees)[problem.times_s >= inputs.settle_s]
        nees = nees[np.isfinite(nees)]
        return CheckRun(group, run, _per_spacecraft(history.err**2, problem.n_spacecraft),
                        fraction((nees >= low) & (nees <= high)))
    except Exception as exc:  # noqa: BLE001 - a worker reports, never raises; but Ctrl-C is not a failed run
        if caused_by_interrupt(exc):
            raise KeyboardInterrupt from exc
        return CheckRun(group, run, None, float("nan"), f"failed ({type(exc).__name__}: {exc})")


def _check_runs(problem: Problem, runs: int, groups: list[tuple], settle_s: float, jobs: int, where: Backend,
                progress: bool):
    """Yield the CheckRun of every (group, run) in group then run order; the first failed run stops the check
    (BudgetError). The runs take a campaign's one path (runner.run_tasks_in_order): a small check stays in this
    process; otherwise its first run is done here (the compiled EKF is then loaded or compiled once, not once
    per worker) and the rest go through the fan-out in task order."""
    if problem.clocks:
        raise BudgetError(f"{problem.scenario.name}: the Monte Carlo check takes scenarios without clocks")
    f = problem.filter
    model_args = (_filter_truth(problem), problem.measurements_true, f.known_states,
                  f.channel_kind, f.channel_ends, f.channel_flags)
    model_y = filter_model_along_truth(*model_args)
    inputs = CheckInputs(problem, model_y, tuple(groups), runs, settle_s)
    for result in run_tasks_in_order(run_check_batch, inputs, problem, len(groups) * runs, jobs, where, progress,
                                     f"{problem.scenario.name} check"):
        if result.reason:
            raise BudgetError(f"{problem.scenario.name}: Monte Carlo run {result.run} of the check with "
                              f"{','.join(groups[result.group])} on {result.reason}")
        yield result


class _GroupSums:
    """One group's check runs, added in run order: the sum of their squared errors (m, n_sc, 2), each run's
    time-mean of it after t0 (runs, n_sc, 2) and each run's share of settled epochs with the NEES in its band.
    Memory: one (m, n_sc, 2) sum per group and 2 n_sc + 1 numbers per run, not a run's history."""

    def __init__(self, problem: Problem):
        self.after_start = problem.times_s > 0.0
        self.total = np.zeros((problem.n_steps, problem.n_spacecraft, 2))
        self.per_run, self.in_band = [], []

    def add(self, result: CheckRun) -> None:
        self.total += result.squared
        self.per_run.append(result.squared[self.after_start].mean(axis=0))
        self.in_band.append(result.nees_in_band)

    def mean_squared(self) -> np.ndarray:
        return self.total / len(self.per_run)

    def nees_in_band(self) -> float:
        return float(np.mean(self.in_band)) if self.in_band else float("nan")


def monte_carlo_check(problem: Problem, budget: Budget, runs: int, sources=SOURCES, settle_s: float = 0.0,
                      jobs: int = 1, where: Backend = LOCAL, progress: bool = False) -> list[dict]:
    """MC over LinCov of the time-mean squared error after t0, per spacecraft and quantity: first with every
    chosen source on, then each alone. A ratio of 1 within Monte Carlo noise validates the budget; that noise
    is in each row (monte_carlo_over_lincov_standard_error: the runs' sample standard deviation of their
    time-mean squared error over sqrt(runs), over LinCov's). Each row also has the runs' mean share of epochs
    after `settle_s` whose NEES lies in its 95 % band (nees_in_band_share_settled: the filter's consistency
    with those sources on). The (1 + len(sources)) x runs EKF runs (runs with a single source) go through the
    one fan-out (`jobs`, `where`); the numbers do not depend on either."""
    use = problem.times_s > 0.0
    rows = []
    groups = [tuple(sources), *([(s,) for s in sources] if len(sources) > 1 else [])]
    sums = [_GroupSums(problem) for _ in groups]
    for result in _check_runs(problem, runs, groups, settle_s, jobs, where, progress):
        sums[result.group].add(result)
    for group, summed in zip(groups, sums):
        mc, per_run, nees_share = summed.mean_squared(), np.array(summed.per_run), summed.nees_in_band()
        parts = [v for k, v in budget.parts.items() if part_of(k) in group]
        lin = sum(parts) if parts else np.zeros_like(budget.total)
        spread = per_run.std(axis=0, ddof=1) / np.sqrt(runs) if runs > 1 else np.full(per_run.shape[1:], np.nan)
        for i, name in enumerate(problem.spacecraft):
            for j, quantity in enumerate(("position", "velocity")):
                expected = lin[use, i, j].mean()
                ratio = float(mc[use, i, j].mean() / expected) if expected > 0 else float("nan")
                standard_error = float(spread[i, j] / expected) if expected > 0 else float("nan")
                rows.append({"sources": ",".join(group), "spacecraft": name, "quantity": quantity,
                             "monte_carlo_m2": float(mc[use, i, j].mean()), "lincov_m2": float(expected),
                             "monte_carlo_over_lincov": ratio,
                             "monte_carlo_over_lincov_standard_error": standard_error, "runs": runs,
                             "nees_in_band_share_settled": nees_share})
    return rows


@dataclass(frozen=True, eq=False)
class BudgetStudy:
    """What `liaison errors` reports: the budget; its shares by part over the whole arc (rows_all) and from
    day 1 (rows_late); the Monte Carlo check's rows (empty without one); the consistency rows after the
    settle time, each with the check's NEES-in-band share (NaN unless every source was checked)."""

    budget: Budget
    rows_all: list
    rows_late: list
    checks: list
    consistency_rows: list
    nees_share: float | None


def budget_study(problem: Problem, sources=SOURCES, check_runs: int = 0, jobs: int = 1, where: Backend = LOCAL,
                 progress: bool = False) -> BudgetStudy:
    """The error budget of `problem`, its shares and consistency, and with check_runs > 0 its Monte Carlo
    check of `sources` (see monte_carlo_check)."""
    budget = error_budget(problem)
    settle_s = problem.scenario.settle_days() * SECONDS_PER_DAY
    checks = (monte_carlo_check(problem, budget, check_runs, sources, settle_s, jobs, where, progress)
              if check_runs else [])
    nees_share = checks[0]["nees_in_band_share_settled"] if checks and tuple(sources) == SOURCES else None
    rows = consistency(budget, settle_s)
    for row in rows:
        row["nees_in_band_share_settled"] = float("nan") if nees_share is None else nees_share
    return BudgetStudy(budget, shares(budget), shares(budget, SECONDS_PER_DAY), checks, rows, nees_share)
