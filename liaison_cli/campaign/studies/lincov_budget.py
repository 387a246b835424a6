"""The LinCov error budget of a problem (estimation.lincov along the truth), by source, and its consistency after the
settle time: the part of `liaison errors` that runs no Monte Carlo (campaign.studies.error_budget adds the checks).
Also what the default process noise's LinCov check reads (campaign.engine.noise_check). Sources and units:
campaign.studies.error_budget's docstring.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.analysis.consistency import verdict
from liaison_cli.campaign.engine.worker import true_parameters
from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.clock import clock_process_noise
from liaison_cli.dynamics.constants import M_PER_LU, M_S_PER_VU
from liaison_cli.errors import LiaisonError
from liaison_cli.estimation.filter_loop import shared_calls
from liaison_cli.estimation.lincov import PART_INITIAL, PART_NOISE, PART_PROCESS, TruthErrors, lincov_along_truth
from liaison_cli.scenario.filter_arrays import biased_filter_params
from liaison_cli.scenario.setup import Problem

LINCOV_DYNAMICS_ARG = 6  # where lincov_along_truth's Dynamics group is (a parameter one sigma off replaces it)
DETERMINISTIC = ("measurement_model", "dynamics_model", "bias_mean")


class BudgetError(LiaisonError):
    """A scenario or option the error budget cannot take."""


@dataclass(frozen=True, eq=False)
class Budget:
    """times_s (m,); spacecraft names; parts {name: (m, n_sc, 2)} second-moment contributions (position m^2,
    velocity (m/s)^2); 'deterministic_cross' holds the cross terms of the deterministic means; total (m, n_sc,
    2); filter_variance (m, n_sc, 2): the filter's own trace of P; total_axes and filter_axes (m, n_sc, 3): the
    position's second moment and the filter's variance per axis of the dynamics model's frame (m^2)."""

    times_s: np.ndarray
    spacecraft: tuple
    parts: dict
    total: np.ndarray
    filter_variance: np.ndarray
    total_axes: np.ndarray | None = None
    filter_axes: np.ndarray | None = None


def _filter_truth(problem: Problem) -> np.ndarray:
    n = problem.filter.layout.n
    truth = np.zeros((problem.n_steps, n))
    truth[:, : problem.truth.shape[1]] = problem.truth
    for start, delta_v, _ in problem.manoeuvres:  # the true Delta-v, as the burn's linearisation point
        truth[:, start : start + 3] = delta_v[None, :]
    for start, value in _parameter_truths(problem):  # the filter's parameter corrections, as its linearisation
        truth[:, start] = value
    return truth


def _inputs(problem: Problem):
    """D_initial, Q_true, S0, d_dyn_extra (filter units) and each channel's unmodelled-bias link."""
    layout = problem.filter.layout
    n, n_sc6 = layout.n, 6 * problem.n_spacecraft
    spec = problem.scenario
    D_initial = np.zeros((n, n))
    if spec.initial_error.draw == "from_covariance":
        D_initial[:n_sc6, :n_sc6] = problem.P0[:n_sc6, :n_sc6]
    else:
        D_initial[:n_sc6, :n_sc6] = np.diag(problem.initial_error_sigma[:n_sc6] ** 2)
    for start, _, sigma in problem.manoeuvres:  # the filter's a-priori Delta-v error
        D_initial[start : start + 3, start : start + 3] = np.eye(3) * sigma**2
    Q_true = np.zeros((n, n))
    d_dyn_extra = np.zeros(n)
    dt_s = spec.measurement.interval_s
    for clock in problem.clocks:
        if clock.state_start < 0:
            continue
        s = slice(clock.state_start, clock.state_start + 2)
        scale = np.array(clock.scale)
        D_initial[s, s] = np.diag((np.array(clock.initial_sigma) * scale) ** 2)
        Q_true[s, s] = clock_process_noise(dt_s, clock.sigma1, clock.sigma2) * np.outer(scale, scale)
        d_dyn_extra[s] = np.array([clock.mu1 * dt_s + clock.mu2 * dt_s**2 / 2, clock.mu2 * dt_s]) * scale
    n_links = len(problem.link_labels)
    S0 = np.zeros((n, n_links))
    bias_link = np.full(len(problem.channels), -1, dtype=np.int64)
    if problem.n_bias:  # biases are filter states (estimated or considered): the filter starts at 0
        for link in range(n_links):
            S0[problem.bias_state_start + link, link] = -1.0
    else:
        for c, ch in enumerate(problem.channels):
            if ch.takes_range_bias:
                bias_link[c] = ch.link
    return D_initial, Q_true, S0, d_dyn_extra, bias_link


def _per_spacecraft(diag_lu, n_sc):
    """(m, n) filter-state diagonal in LU units -> (m, n_sc, 2): position m^2, velocity (m/s)^2."""
    m = diag_lu.shape[0]
    blocks = diag_lu[:, : 6 * n_sc].reshape(m, n_sc, 6)
    return np.stack([blocks[:, :, 0:3].sum(axis=2) * M_PER_LU**2, blocks[:, :, 3:6].sum(axis=2) * M_S_PER_VU**2],
                    axis=2)


def _position_axes(diag_lu, n_sc):
    """(m, n) filter-state diagonal in LU units -> (m, n_sc, 3): each spacecraft's position variance per axis, m^2."""
    return diag_lu[:, : 6 * n_sc].reshape(diag_lu.shape[0], n_sc, 6)[:, :, 0:3] * M_PER_LU**2


def error_budget(problem: Problem) -> Budget:
    if problem.filter.ric_noise is not None:
        raise BudgetError(f"{problem.scenario.name}: process_noise_psd_ric_m2_s3: LinCov takes a fixed process "
                          "noise per step; allowed: process_noise_psd_m2_s3 or process_noise_accel_m_s2")
    drawn_force = problem.scenario.model_error.truth_acceleration_sigma_m_s2
    if drawn_force > 0.0:  # LinCov flies the one shared truth and has no part for a force drawn per run
        raise BudgetError(f"{problem.scenario.name}: model_error.truth_acceleration_sigma_m_s2 = {drawn_force:g}: "
                          "the budget linearises about one shared truth, and each run of this scenario flies its "
                          "own; allowed: 0 (a constant truth_acceleration_m_s2 is budgeted)")
    if not problem.scenario.estimator_descriptor().error_budget:
        raise BudgetError(f"{problem.scenario.name}: the error budget splits the EKF's error; this scenario's "
                          f"estimator is {problem.scenario.estimator!r}")
    f = problem.filter
    # The arrays the shared calls take, C-contiguous and writable as they are typed (filter_loop.shared_calls).
    D_initial, Q_true, S0, d_dyn_extra, bias_link = _inputs(problem)
    args = (int(f.model), _filter_truth(problem), problem.measurements_true, writable_c(f.known_states),
            f.channels(), f.block_layout(), f.dynamics(), f.P0, writable_c(f.Q), int(f.n_gain), float(f.underweight),
            f.burns, TruthErrors(D_initial, writable_c(Q_true), S0, d_dyn_extra, bias_link),
            shared_calls(f.channels(), f.block_layout(), f.dynamics()))
    run_lincov = lincov_along_truth
    P_diag, D_diag, S, mu_meas, mu_dyn = run_lincov(*args)
    n_sc = problem.n_spacecraft
    random_diag = {"initial": D_diag[:, PART_INITIAL], "noise": D_diag[:, PART_NOISE],
                   "process": D_diag[:, PART_PROCESS]}  # each part's variance per filter state, LU
    bias_sigma = problem.bias_sigma_lu
    for link, label in enumerate(problem.link_labels):
        random_diag[f"bias {label}"] = S[:, :, link] ** 2 * bias_sigma**2
    parts = {name: _per_spacecraft(diag, n_sc) for name, diag in random_diag.items()}
    bias_mean = S @ np.full(len(problem.link_labels), problem.bias_lu)
    means = {"measurement_model": mu_meas, "dynamics_model": mu_dyn, "bias_mean": bias_mean}
    for name, mean in means.items():
        parts[name] = _per_spacecraft(mean**2, n_sc)
    for name, draws in (("cr", (problem.scenario.cr_error_sigma(), 0.0)),
                        ("moon_gm", (0.0, problem.scenario.model_error.moon_gm_sigma))):
        if max(draws) > 0.0:  # the filter's parameter one sigma off: the change of the dynamics mean
            off_by_sigma = list(args)
            scaled = biased_filter_params(problem.scenario, problem.dynamics, *draws)
            off_by_sigma[LINCOV_DYNAMICS_ARG] = f.dynamics()._replace(params=scaled)
            random_diag[name] = (run_lincov(*off_by_sigma)[4] - mu_dyn) ** 2
            parts[name] = _per_spacecraft(random_diag[name], n_sc)
    total_mean = mu_meas + mu_dyn + bias_mean
    parts["deterministic_cross"] = _per_spacecraft(total_mean**2, n_sc) - sum(parts[k] for k in DETERMINISTIC)
    total = sum(parts.values())
    total_axes = _position_axes(sum(random_diag.values()) + total_mean**2, n_sc)
    return Budget(problem.times_s, problem.spacecraft, parts, total, _per_spacecraft(P_diag, n_sc), total_axes,
                  _position_axes(P_diag, n_sc))


def _parameter_truths(problem: Problem):
    """(state offset, true value) of each dynamics-parameter state for a filter with model_error's fixed errors
    only (worker.true_parameters at the fixed C_R factor)."""
    return true_parameters(problem, 1.0 + problem.scenario.model_error.cr_bias)


def consistency(budget: Budget, settle_s: float) -> list[dict]:
    """Per spacecraft over the epochs from `settle_s` on: the error RMS the budget predicts (the root of the
    time-mean of its total second moment, every source on) and the filter's sigma RMS (root of the time-mean
    of its trace(P)), of position (m) and velocity (m/s), their ratio (error_to_sigma: analysis.metrics' campaign
    ratio, for an infinite campaign), and `consistent`: both ratios within [1/1.5, 1.5] (the ratio test of
    analysis.consistency.verdict with no interval: LinCov has no sampling
    noise; a budget has no NEES, its check runs do)."""
    settled = budget.times_s >= settle_s
    rows = []
    for i, name in enumerate(budget.spacecraft):
        row = {"spacecraft": name, "settle_s": float(settle_s)}
        for j, (kind, unit) in enumerate((("position", "m"), ("velocity", "m_s"))):
            error = float(np.sqrt(max(budget.total[settled, i, j].mean(), 0.0)))
            sigma = float(np.sqrt(budget.filter_variance[settled, i, j].mean()))
            row[f"error_rms_{kind}_{unit}"] = error
            row[f"sigma_rms_{kind}_{unit}"] = sigma
            row[f"{kind}_error_to_sigma"] = error / sigma if sigma > 0 else float("nan")
        row["consistent"] = verdict({}, {kind: (row[f"{kind}_error_to_sigma"], 0.0)
                                         for kind in ("position", "velocity")})[0]
        rows.append(row)
    return rows
