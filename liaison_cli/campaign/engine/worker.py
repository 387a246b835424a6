"""One Monte Carlo run as a work unit. A worker never raises: a failure is an outcome with a status."""

from dataclasses import dataclass, field, replace

import numpy as np

from liaison_cli.analysis.consistency import direction_columns, run_verdict
from liaison_cli.analysis.epoch_states import epoch_state_columns, sampled_epochs
from liaison_cli.analysis.ric import primaries_lu, primary_velocities_lu, ric_columns
from liaison_cli.analysis.metrics import (
    error_and_sigma,
    error_norms,
    nees_divergence_limit,
    summary_rows,
    sustained_excess_step,
)
from liaison_cli.campaign.engine.clock_record import add_clock_sync, estimated_clock_histories
from liaison_cli.campaign.engine.seeding import run_rng, truth_force_rng
from liaison_cli.dynamics.clock import simulate_clock
from liaison_cli.dynamics.constants import M_PER_LU, M_S2_PER_AU, M_S_PER_VU, SECONDS_PER_DAY
from liaison_cli.dynamics.random_forcing import gauss_markov_samples
from liaison_cli.estimation.blocks import BLOCK_EMPIRICAL, BLOCK_PARAMETER, FORMATION
from liaison_cli.estimation.estimators import estimate
from liaison_cli.estimation.kernel_args import MAX_DIRECTION_SAMPLES
from liaison_cli.interrupts import caused_by_interrupt
from liaison_cli.scenario.filter_arrays import biased_filter_params
from liaison_cli.scenario.setup import Problem
from liaison_cli.scenario.truth import forced_truth_and_measurements


@dataclass(frozen=True)
class RunTask:
    run_index: int


@dataclass(frozen=True, eq=False)
class RunOutcome:
    """status: 'ok', 'diverged' (filter health check tripped) or 'error' (exception in the worker).

    Arrays: norms[...] (m, n_sc) in m and m/s; nees (m,); innovation_m / innovation_std_m (m, C) per
    measurement channel in SI units (m, m/s or rad; see Problem.channel_labels); rejected (m, C): True where
    the EKF's residual gate refused the measurement (all False without a gate).
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
    clock_error_s: np.ndarray | None = None  # (m, n_clocks, 2) phase (s) and frequency (s/s) errors
    clock_sigma_s: np.ndarray | None = None  # (m, n_clocks, 2) their 1-sigma
    rejected: np.ndarray | None = None  # (m, C) bool, see above
    epoch_states: dict | None = None  # states.parquet's columns of this run (output.epoch_states_runs), else None


@dataclass(frozen=True, eq=False)
class RunInputs:
    """x0_hat (n,) initial estimate; y_obs (m, C) observed values; truth (m, n) the true filter states
    (spacecraft, clocks, biases); bias_lu (L,) the true range bias of each link."""

    x0_hat: np.ndarray
    y_obs: np.ndarray
    truth: np.ndarray
    bias_lu: np.ndarray
    clock_phase_s: dict = field(default_factory=dict)  # {owner: (m,) true clock phase in s}
    filter_params: np.ndarray | None = None  # this run's dynamics parameters for the filter (a drawn C_R error)


def draw_run_inputs(problem: Problem, run_index: int) -> RunInputs:
    """Everything random in one run, from (scenario seed, run index) alone.

    Draw order is part of the reproducibility contract: initial error first, then measurement noise
    (one channel after another), then the per-run random bias of each link, then each clock's history,
    then the filter's C_R error, then each manoeuvre's a-priori error. A random truth acceleration is drawn
    from a stream of its own (run_truth), so it moves none of these.
    """
    # measurements: {tdm}: the draws of the run the file names, then the file's values replace the simulated ones.
    rng = run_rng(problem.scenario.monte_carlo.seed, run_index if problem.observed is None else problem.observed.run)
    own_truth, measurements_true, forcing = run_truth(problem, run_index)
    n = own_truth.shape[1]
    if problem.scenario.initial_error.draw == "from_covariance":
        dx0 = np.linalg.cholesky(problem.P0[:n, :n]) @ rng.standard_normal(n)
    else:
        dx0 = problem.initial_error_sigma[:n] * rng.standard_normal(n)
    m, n_channels = measurements_true.shape
    # Channel by channel (column-major), so a channel's noise does not depend on which other channels a
    # scenario has: range-only and range + range-rate runs share their range noise.
    noise = rng.standard_normal((n_channels, m - 1)).T * problem.sigma_lu
    n_links = len(problem.link_labels)
    if problem.scenario.noise.bias_distribution == "uniform":  # same variance, bounded (003)
        bias = problem.bias_lu + problem.bias_sigma_lu * np.sqrt(3.0) * rng.uniform(-1.0, 1.0, n_links)
    else:
        bias = problem.bias_lu + problem.bias_sigma_lu * rng.standard_normal(n_links)
    y_obs = measurements_true.copy()
    y_obs[1:] += noise
    biased = np.array([ch.takes_range_bias for ch in problem.channels])
    y_obs[1:, biased] += bias[problem.channel_link[biased]][None, :]

    n_state = problem.filter.layout.n
    truth = np.zeros((m, n_state))
    truth[:, :n] = own_truth
    dt_s = problem.scenario.measurement.interval_s
    phases = {}
    for clock in problem.clocks:
        x0 = np.array(clock.initial_sigma) * rng.standard_normal(2)
        history_s = simulate_clock(rng, m, dt_s, x0, clock.sigma1, clock.sigma2, mu1=clock.mu1, mu2=clock.mu2)
        phases[clock.owner] = history_s[:, 0]
        history = history_s * np.array(clock.scale)
        if clock.state_start >= 0:
            truth[:, clock.state_start : clock.state_start + 2] = history
        for channel, coeff in clock.channels:
            y_obs[1:, channel] += coeff * history[1:, 0]
    if problem.n_bias:
        truth[:, problem.bias_state_start : problem.bias_state_start + problem.n_bias] = bias[None, :]
    # The filter starts its clock and bias states at their a-priori mean, zero.
    x0_hat = np.concatenate([own_truth[0] + dx0, np.zeros(n_state - n)])
    filter_params, cr_factor = _filter_params(problem, rng)
    for start, value in true_parameters(problem, cr_factor):
        truth[:, start] = value
    for start, value in true_empirical_accelerations(problem, forcing):
        truth[:, start : start + 3] = value
    # Manoeuvres (drawn last): the truth keeps the scenario's Delta-v, the filter starts its a-priori sigma off.
    for start, delta_v, sigma in problem.manoeuvres:
        truth[:, start : start + 3] = delta_v[None, :]
        x0_hat[start : start + 3] = delta_v + sigma * rng.standard_normal(3)
    if problem.observed is not None:
        y_obs = problem.observed.values.copy()
    return RunInputs(x0_hat, y_obs, truth, bias, phases, filter_params)


def _filter_params(problem: Problem, rng):
    """(the filter's dynamics parameters of this run, the factor between the filter's C_R and the truth's) when
    scenario.model_error draws per run: C_R off by a factor 1 + N(0, cr sigma) (003: 5 %), then the Moon's GM
    by 1 + N(0, moon_gm_sigma), each drawn only when its sigma is set, and last, so no other draw moves; the
    fixed errors on top (filter_arrays.biased_filter_params). Parameters None when nothing is drawn (the
    problem's filter parameters hold)."""
    scenario = problem.scenario
    cr_sigma, gm_sigma = scenario.cr_error_sigma(), scenario.model_error.moon_gm_sigma
    fixed_cr_factor = 1.0 + scenario.model_error.cr_bias
    if cr_sigma == 0.0 and gm_sigma == 0.0:
        return None, fixed_cr_factor
    cr_draw = cr_sigma * rng.standard_normal() if cr_sigma > 0.0 else 0.0
    gm_draw = gm_sigma * rng.standard_normal() if gm_sigma > 0.0 else 0.0
    return biased_filter_params(scenario, problem.dynamics, cr_draw, gm_draw), fixed_cr_factor * (1.0 + cr_draw)


def true_parameters(problem: Problem, cr_factor: float):
    """(state offset, true value) of every dynamics-parameter block (filter.estimated_parameters): the C_R
    correction that brings the filter's C_R (the truth's times cr_factor) back to the truth's, 1 / cr_factor - 1."""
    true_value = {"cr": 1.0 / cr_factor - 1.0}
    layout = problem.filter.layout
    return [(int(start), true_value[block.owner.split(" ", 1)[0]])
            for block, start in zip(layout.blocks, layout.starts) if block.kind == BLOCK_PARAMETER]


def true_empirical_accelerations(problem: Problem, forcing: dict | None = None):
    """(state offset, true value (m, 3) or (3,) in LU/TU^2) of every empirical-acceleration block
    (filter.empirical_acceleration): the acceleration the truth feels that the filter's dynamics lack,
    model_error.truth_acceleration_m_s2 (zero when none), plus the run's drawn one at each epoch (`forcing`
    {spacecraft name: (m, 3)}, run_truth's), on the same axes."""
    constant = np.array(problem.scenario.model_error.truth_acceleration_m_s2) / M_S2_PER_AU
    layout = problem.filter.layout
    return [(int(start), constant + (forcing or {}).get(block.owner.split(" ", 1)[1], 0.0))
            for block, start in zip(layout.blocks, layout.starts) if block.kind == BLOCK_EMPIRICAL]


def run_truth(problem: Problem, run_index: int):
    """(truth (m, 6 n_sc) of the estimated spacecraft, noise-free measurements (m, C), {name: drawn
    acceleration (m, 3) in LU/TU^2} or None) of one run: the problem's shared ones, or, with a random truth
    acceleration (model_error.truth_acceleration_sigma_m_s2), the run's own, flown under a Gauss-Markov path
    per estimated spacecraft drawn from the run's truth-force stream (seeding.truth_force_rng)."""
    if problem.unforced is None:
        return problem.truth, problem.measurements_true, None
    error = problem.scenario.model_error
    draws = gauss_markov_samples(truth_force_rng(problem.scenario.monte_carlo.seed, run_index),
                                 problem.n_spacecraft, problem.n_steps, problem.scenario.measurement.interval_s,
                                 error.truth_acceleration_sigma_m_s2 / M_S2_PER_AU,
                                 error.truth_acceleration_time_constant_s)
    forcing = dict(zip(problem.spacecraft, draws))
    initial_states = {name: problem.truth[0, 6 * i : 6 * i + 6] for i, name in enumerate(problem.spacecraft)}
    flown, measurements = forced_truth_and_measurements(problem.scenario, problem.dynamics, problem.times_s,
                                                        problem.unforced, initial_states, forcing)
    truth = np.ascontiguousarray(np.hstack([flown[name].states for name in problem.spacecraft]))
    return truth, np.ascontiguousarray(measurements), forcing


def execute_run(problem: Problem, task: RunTask) -> RunOutcome:
    run = task.run_index
    try:
        inputs = draw_run_inputs(problem, run)
        arrays = problem.filter if inputs.filter_params is None else replace(problem.filter,
                                                                             model_params=inputs.filter_params)
        history = _check_consistency(problem, estimate(problem.scenario.estimator, arrays, inputs.x0_hat,
                                                       inputs.y_obs, inputs.truth))
        n_dyn = 6 * problem.n_spacecraft
        err, sigma = history.err, history.sigma
        summary, norms = summary_rows(problem.times_s, err[:, :n_dyn], sigma[:, :n_dyn], problem.spacecraft,
                                      M_PER_LU, M_S_PER_VU, data_end_step=history.data_end_step,
                                      settle_s=problem.scenario.settle_days() * SECONDS_PER_DAY,
                                      nees=history.nees, n_nees=problem.filter.n_nees)
        _add_directions(problem, arrays, history, summary)
        _add_parameters(problem, inputs, history, summary)
        _add_empirical(problem, history, summary)
        _add_ric(problem, inputs, history, summary, n_dyn)
        _add_estimator_extras(summary, history.extras, problem.scenario.measurement.interval_s)
        _add_smoothed(problem, history, summary, norms, n_dyn)
        sync_error, sync_sigma = add_clock_sync(problem, inputs.clock_phase_s, inputs.y_obs, history.data_end_step,
                                                summary)
        states = _epoch_states(problem, inputs, history, n_dyn) if run < problem.scenario.output.epoch_states_runs else None
        last = history.fail_step - 1 if not history.ok else -1
        bias = inputs.bias_lu
        if problem.n_bias:
            columns = slice(problem.bias_state_start, problem.bias_state_start + problem.n_bias)
            bias_estimate = (err[last, columns] + bias) * M_PER_LU
            bias_sigma = sigma[last, columns] * M_PER_LU
        else:
            bias_estimate = np.zeros_like(bias)
            bias_sigma = np.full_like(bias, np.nan)
        scale = problem.channel_scale_si
        clock_error, clock_sigma = estimated_clock_histories(problem, err, sigma)
        if clock_error is None:  # no clock states: clock_sync's fitted clocks, if any (clock_record)
            clock_error, clock_sigma = sync_error, sync_sigma
        rejected = np.zeros(history.innovation.shape, dtype=bool) if history.rejected is None else history.rejected
        summary = summary if history.ok else _nan_summary(summary, norms, history.fail_step)
        _add_rejections(problem, history.innovation, rejected, summary)  # kept for a diverged run: why it failed
        return RunOutcome(
            run=run,
            status="ok" if history.ok else "diverged",
            reason=history.reason,
            fail_time_s=float("nan") if history.ok else float(problem.times_s[history.fail_step]),
            summary=summary,
            norms=norms,
            nees=history.nees,
            innovation_m=history.innovation * scale,
            innovation_std_m=history.innovation_std * scale,
            bias_true_m=bias * M_PER_LU,
            bias_estimate_m=bias_estimate,
            bias_sigma_m=bias_sigma,
            clock_error_s=clock_error,
            clock_sigma_s=clock_sigma,
            rejected=rejected,
            epoch_states=states,
        )
    except Exception as exc:  # noqa: BLE001 - a worker reports, never raises; but Ctrl-C is not a failed run
        if caused_by_interrupt(exc):
            raise KeyboardInterrupt from exc
        return RunOutcome(run=run, status="error", reason=f"{type(exc).__name__}: {exc}", fail_time_s=float("nan"))


def _add_directions(problem: Problem, arrays, history, summary) -> None:
    """Consistency by direction (analysis.consistency.direction_columns) into every spacecraft row, then each
    row's verdict: consistent_settled and consistency_failed."""
    starts, pairs = arrays.direction_starts()
    block_of = {int(a): i for i, a in enumerate(starts)}
    names = [f"{problem.spacecraft[block_of[int(a)]]}-{problem.spacecraft[block_of[int(b)]]}" for a, b in pairs]
    per_spacecraft, run = direction_columns(problem.times_s, history.directions,
                                            problem.scenario.settle_days() * SECONDS_PER_DAY, len(summary), names,
                                            problem.scenario.measurement.interval_s)
    for row, own in zip(summary, per_spacecraft):
        row.update(own)
        row.update(run)
        row["consistent_settled"], row["consistency_failed"] = run_verdict(row)


def _add_parameters(problem: Problem, inputs: RunInputs, history, summary) -> None:
    """The estimated dynamics parameters (filter.estimated_parameters) into their spacecraft's row (a formation's
    into every row, as the run's): the true
    value, the error and sigma at the last healthy epoch, and the RMS of the error and of sigma over the
    settled epochs (dimensionless, as the states)."""
    layout, settled, row_of = _blocks_and_rows(problem, summary)
    for block, start in zip(layout.blocks, layout.starts):
        if block.kind != BLOCK_PARAMETER:
            continue
        name, owner = block.owner.split(" ", 1)
        rows = summary if owner == FORMATION else [row_of[owner]]
        err, sigma = history.err[:, start], history.sigma[:, start]
        healthy = np.flatnonzero(np.isfinite(err))
        last = healthy[-1] if healthy.size else 0
        settled_err, settled_sigma = err[settled & np.isfinite(err)], sigma[settled & np.isfinite(err)]
        columns = {
            f"{name}_true": float(inputs.truth[0, start]),
            f"{name}_error_final": float(err[last]) if healthy.size else np.nan,
            f"{name}_sigma_final": float(sigma[last]) if healthy.size else np.nan,
            f"rms_{name}_error_settled": float(np.sqrt(np.mean(settled_err**2))) if settled_err.size else np.nan,
            f"sigma_{name}_settled": float(np.sqrt(np.mean(settled_sigma**2))) if settled_err.size else np.nan}
        for row in rows:
            row.update(columns)


def _blocks_and_rows(problem: Problem, summary):
    """(the filter's state layout, the settled epochs (m,) bool, {spacecraft name: its summary row})."""
    settled = problem.times_s >= problem.scenario.settle_days() * SECONDS_PER_DAY
    return problem.filter.layout, settled, {name: row for name, row in zip(problem.spacecraft, summary)}


def _add_empirical(problem: Problem, history, summary) -> None:
    """Each spacecraft's empirical acceleration (filter.empirical_acceleration) into its row: the RMS over the
    settled epochs of its 3-D error and of its RSS sigma (m/s^2)."""
    layout, settled, row_of = _blocks_and_rows(problem, summary)
    for block, start in zip(layout.blocks, layout.starts):
        if block.kind != BLOCK_EMPIRICAL:
            continue
        err = history.err[:, start : start + 3] * M_S2_PER_AU
        sigma = history.sigma[:, start : start + 3] * M_S2_PER_AU
        use = settled & np.all(np.isfinite(err), axis=1)
        row = row_of[block.owner.split(" ", 1)[1]]
        row["rms_accel_error_settled_m_s2"] = float(np.sqrt(np.mean(np.sum(err[use] ** 2, axis=1)))) if use.any() else np.nan
        row["sigma_accel_settled_m_s2"] = float(np.sqrt(np.mean(np.sum(sigma[use] ** 2, axis=1)))) if use.any() else np.nan


_PRIMARIES: dict = {}


def _primaries(problem: Problem):
    """(positions, velocities) (m, 2, 3) of the Earth and the Moon at the problem's epochs (analysis.ric), kept
    for the last few problems this worker saw."""
    key = id(problem)
    if key not in _PRIMARIES or _PRIMARIES[key][0] is not problem:
        if len(_PRIMARIES) >= 4:
            _PRIMARIES.pop(next(iter(_PRIMARIES)))
        positions = primaries_lu(problem.mu, problem.dynamics.body_positions_lu(problem.times_s), problem.times_s)
        step_s = float(problem.times_s[1] - problem.times_s[0]) if problem.n_steps > 1 else 1.0
        _PRIMARIES[key] = (problem, positions, primary_velocities_lu(positions, step_s))
    return _PRIMARIES[key][1:]


def _epoch_states(problem: Problem, inputs: RunInputs, history, n_dyn: int) -> dict:
    """This run's rows of states.parquet (analysis.epoch_states), at the epochs the EKF's covariance record holds
    (with an initial batch those count from its handover, not from t0; a diverged run's end where it stopped), or,
    for an estimator without one, every k-th epoch by the record's rule; with t_s; the writer adds run and epoch
    columns."""
    m = len(problem.times_s)
    directions = history.directions
    recorded = (np.flatnonzero(np.isfinite(directions.covariance[:, 0, 0])) if directions is not None
                else np.zeros(0, dtype=np.int64))
    rows = recorded if len(recorded) else sampled_epochs(m, max(1, -(-m // MAX_DIRECTION_SAMPLES)))
    positions, velocities = _primaries(problem)
    columns = {"t_s": np.repeat(np.asarray(problem.times_s, dtype=float)[rows], problem.n_spacecraft)}
    columns.update(epoch_state_columns(rows, history.err[:, :n_dyn], history.sigma[:, :n_dyn], inputs.truth[:, :n_dyn],
                                       None if directions is None else directions.covariance, positions, velocities,
                                       problem.spacecraft, M_PER_LU, M_S_PER_VU))
    return columns


def _add_ric(problem: Problem, inputs: RunInputs, history, summary, n_dyn: int) -> None:
    """Each spacecraft's errors and sigmas along its radial / in-track / cross-track axes (analysis.ric)."""
    positions, velocities = _primaries(problem)
    covariance = None if history.directions is None else history.directions.covariance
    rows = ric_columns(problem.times_s, history.err[:, :n_dyn], inputs.truth[:, :n_dyn], covariance, positions,
                       problem.scenario.settle_days() * SECONDS_PER_DAY, M_PER_LU, M_S_PER_VU, velocities)
    for row, own in zip(summary, rows):
        row.update(own)


def _check_consistency(problem: Problem, history):
    """The estimator's own health checks, plus the consistency rule: a run whose whole-state NEES stays above
    divergence_nees_factor x its 99.9 % chi-square quantile for divergence_window_days has lost track (its
    errors are many sigmas out, not merely optimistic) and is diverged from the epoch that completes the
    window."""
    if not history.ok:
        return history
    spec = problem.scenario.filter
    limit = nees_divergence_limit(problem.filter.n_nees, spec.divergence_nees_factor)
    window = int(round(spec.divergence_window_days * SECONDS_PER_DAY / problem.scenario.measurement.interval_s))
    step = sustained_excess_step(history.nees, limit, window)
    if step < 0:
        return history
    reason = (f"diverged: NEES above {limit:.4g} ({spec.divergence_nees_factor:g} x the 99.9 % chi-square "
              f"quantile of {problem.filter.n_nees} states) for {spec.divergence_window_days:g} d")
    return replace(history, ok=False, reason=reason, fail_step=step)


def _add_smoothed(problem: Problem, history, summary, norms, n_dyn: int) -> None:
    """filter.smoother: rts. The smoothed history's error norms and 3-sigma bounds per epoch go beside the
    filter's (timeseries.parquet: *_smoothed_*), and each spacecraft's row gets the smoothed error RMS and
    sigma RMS over all epochs after t0 with their ratio (smoothing has no transient to settle)."""
    if history.smoothed_err is None or not history.ok:  # a diverged run (NEES rule included) is not smoothed
        return
    smoothed = error_norms(history.smoothed_err[:, :n_dyn], history.smoothed_sigma[:, :n_dyn], M_PER_LU, M_S_PER_VU)
    for kind, unit in (("position", "m"), ("velocity", "m_s")):
        for what in ("error", "3sigma"):
            norms[f"{kind}_{what}_smoothed_{unit}"] = smoothed[f"{kind}_{what}_{unit}"]
    after_t0 = problem.times_s > 0.0
    for i, row in enumerate(summary):
        row.update(error_and_sigma(smoothed, after_t0, i, "smoothed"))


def _add_estimator_extras(summary, extras, interval_s: float) -> None:
    """A batch solve's iteration count and condition number, in every spacecraft's row; with an initial batch
    (filter.initial_batch_hours), its window (h), iterations and post-fit chi-square per measurement."""
    if not extras:
        return
    if "initial_batch_epochs" in extras:
        for row in summary:
            row["initial_batch_window_h"] = extras["initial_batch_epochs"] * interval_s / 3600.0
            row["initial_batch_iterations"] = float(extras["initial_batch_iterations"])
            row["initial_batch_chi2_per_measurement"] = float(extras["initial_batch_chi2_per_measurement"])
        return
    windows = extras.get("windows", [])
    for i, row in enumerate(summary):
        row["batch_iterations"] = float(extras["iterations"])
        row["batch_condition"] = float(extras["condition"])
        if len(windows) > 1:  # every window's prediction, pooled (the row's own prediction is the last window's)
            values = np.array([w["prediction_rms_lu"][i] for w in windows])
            row["rms_position_prediction_all_windows_m"] = float(np.sqrt(np.mean(values**2))) * M_PER_LU


def _add_rejections(problem: Problem, innovation, rejected, summary) -> None:
    """With the residual gate on (filter.residual_gate_sigma), every spacecraft's row gets the run's totals
    over all links: rejected_measurements, the measurements the gate refused, and rejected_share, their
    share of the measurements the filter processed (a share far above 2 (1 - Phi(k)) says the filter has
    lost track and edits good data: a gate locked out). Per link: residuals.parquet, column rejected."""
    if problem.filter.residual_gate_sigma <= 0.0:
        return
    count = int(rejected.sum())
    processed = int(np.isfinite(innovation).sum())
    for row in summary:
        row["rejected_measurements"] = count
        row["rejected_share"] = count / processed if processed else float("nan")


def _nan_summary(rows, norms, fail_step: int):
    """A diverged run keeps its rows (with status) but no metrics, so it cannot be averaged in; each row keeps
    how far off its spacecraft was when the run was stopped (fail_position_error_m: the last finite position
    error at or before the failure epoch)."""
    out = [{k: (v if k == "spacecraft" else "" if isinstance(v, str) else float("nan")) for k, v in row.items()}
           for row in rows]
    errors = norms["position_error_m"][: max(fail_step, 0) + 1]
    for i, row in enumerate(out):
        finite = errors[np.isfinite(errors[:, i]), i]
        row["fail_position_error_m"] = float(finite[-1]) if finite.size else float("nan")
    return out


__all__ = ["RunTask", "RunOutcome", "RunInputs", "execute_run", "draw_run_inputs"]
