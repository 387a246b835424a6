"""One Monte Carlo run as a work unit. A worker never raises: a failure is an outcome with a status."""

from dataclasses import dataclass, field

import numpy as np

from liaison_cli.analysis.metrics import summary_rows
from liaison_cli.campaign.problem import Problem
from liaison_cli.dynamics.constants import M_PER_LU, M_S_PER_VU
from liaison_cli.campaign.seeding import run_rng
from liaison_cli.estimation.filter_loop import KIND_RANGE, STATUS_NAMES, STATUS_OK, run_ekf


@dataclass(frozen=True)
class RunTask:
    run_index: int


@dataclass(frozen=True, eq=False)
class RunOutcome:
    """status: 'ok', 'diverged' (filter health check tripped) or 'error' (exception in the worker).

    Arrays: norms[...] (m, n_sc) in m and m/s; nees (m,); innovation_m / innovation_std_m (m, C) per
    measurement channel in SI units (m, m/s or rad; see Problem.channel_units).
    """

    run: int
    status: str
    reason: str
    fail_time_s: float
    summary: list = field(default_factory=list)
    norms: dict = field(default_factory=dict)
    nees: np.ndarray | None = None
    innovation_m: np.ndarray | None = None
    innovation_std_m: np.ndarray | None = None
    bias_true_m: np.ndarray | None = None  # (L,) per link
    bias_estimate_m: np.ndarray | None = None  # (L,) final filter value (a-priori mean if not estimated)
    bias_sigma_m: np.ndarray | None = None  # (L,) final 1-sigma (NaN if the filter has no bias state)


def draw_run_inputs(problem: Problem, run_index: int, with_bias: bool = False):
    """Initial estimate (n,) and observed measurements (m, L) of one run; with_bias also returns the true
    range bias of each link (L,) in LU.

    Draw order is part of the reproducibility contract: initial error first, then measurement noise
    (one channel after another), then the per-run random bias of each link.
    """
    rng = run_rng(problem.scenario.monte_carlo.seed, run_index)
    n = problem.truth.shape[1]
    if problem.scenario.initial_error.draw == "from_covariance":
        dx0 = np.linalg.cholesky(problem.P0[:n, :n]) @ rng.standard_normal(n)
    else:
        dx0 = problem.initial_error_sigma[:n] * rng.standard_normal(n)
    m, n_channels = problem.measurements_true.shape
    # Channel by channel (column-major), so a channel's noise does not depend on which other channels a
    # scenario has: range-only and range + range-rate runs share their range noise.
    noise = rng.standard_normal((n_channels, m - 1)).T * problem.sigma_lu
    n_links = len(problem.link_receiver)
    bias = problem.bias_lu + problem.bias_sigma_lu * rng.standard_normal(n_links)
    y_obs = problem.measurements_true.copy()
    y_obs[1:] += noise
    ranges = problem.channel_kind == KIND_RANGE  # biases affect range channels only
    y_obs[1:, ranges] += bias[problem.channel_link[ranges]][None, :]
    x0_hat = problem.truth[0] + dx0
    if problem.n_bias:  # the filter starts its bias states at their a-priori mean, zero
        x0_hat = np.concatenate([x0_hat, np.zeros(problem.n_bias)])
    return (x0_hat, y_obs, bias) if with_bias else (x0_hat, y_obs)


def execute_run(problem: Problem, task: RunTask) -> RunOutcome:
    run = task.run_index
    try:
        x0_hat, y_obs, bias = draw_run_inputs(problem, run, with_bias=True)
        truth = problem.truth
        if problem.n_bias:
            truth = np.hstack([truth, np.repeat(bias[None, :], truth.shape[0], axis=0)])
        err, sigma, nees, innovation, innovation_std, status, fail_step = run_ekf(
            x0_hat,
            problem.P0,
            problem.Q,
            truth,
            y_obs,
            problem.link_receiver,
            problem.link_transponder,
            problem.channel_link,
            problem.channel_kind,
            problem.sigma_lu,
            problem.dt_tu,
            problem.substeps,
            problem.mu,
            problem.divergence_position_lu,
            problem.light_time_model,
            problem.n_spacecraft,
            problem.bias_mode,
        )
        n_dyn = 6 * problem.n_spacecraft
        summary, norms = summary_rows(problem.times_s, err[:, :n_dyn], sigma[:, :n_dyn], problem.spacecraft,
                                      M_PER_LU, M_S_PER_VU)
        last = fail_step - 1 if status != STATUS_OK else -1
        if problem.n_bias:
            bias_estimate = (err[last, n_dyn:] + bias) * M_PER_LU
            bias_sigma = sigma[last, n_dyn:] * M_PER_LU
        else:
            bias_estimate = np.zeros_like(bias)
            bias_sigma = np.full_like(bias, np.nan)
        ok = status == STATUS_OK
        return RunOutcome(
            run=run,
            status="ok" if ok else "diverged",
            reason="" if ok else STATUS_NAMES[int(status)],
            fail_time_s=float("nan") if ok else float(problem.times_s[fail_step]),
            summary=summary if ok else _nan_summary(summary),
            norms=norms,
            nees=nees,
            innovation_m=innovation * problem.channel_scale_si,
            innovation_std_m=innovation_std * problem.channel_scale_si,
            bias_true_m=bias * M_PER_LU,
            bias_estimate_m=bias_estimate,
            bias_sigma_m=bias_sigma,
        )
    except Exception as exc:  # noqa: BLE001 - a worker reports, never raises
        return RunOutcome(run=run, status="error", reason=f"{type(exc).__name__}: {exc}", fail_time_s=float("nan"))


def _nan_summary(rows):
    """A diverged run keeps its rows (with status) but no metrics, so it cannot be averaged in."""
    return [{k: (v if k == "spacecraft" else float("nan")) for k, v in row.items()} for row in rows]


__all__ = ["RunTask", "RunOutcome", "execute_run", "draw_run_inputs"]
