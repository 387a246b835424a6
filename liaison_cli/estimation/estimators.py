"""Estimators behind one interface: `estimate(name, arrays, x0_hat, y_obs, truth) -> EstimateHistory`.

`FilterArrays` is everything an estimator may use: the state layout, the a-priori and process-noise
matrices, the channels (kind, ends, flags, modifiers, sigma), the known participants' states and the
dynamics model as code + parameters. The history it returns is the same whatever the estimator: per-epoch
errors and sigmas, NEES, innovations per channel, a status and the step at which it failed.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.estimation.batch import BATCH_OK, postfit_residuals, solve_batch
from liaison_cli.estimation.blocks import BLOCK_SPACECRAFT, StateLayout
from liaison_cli.estimation.filter_loop import STATUS_NAMES, STATUS_OK, run_ekf


@dataclass(frozen=True, eq=False)
class BatchArrays:
    """The batch solve's settings: counts (m - 1,) RK8 steps per interval; epochs 0..n_use-1 carry its data;
    a-priori information on or off; iteration limit, tolerance (LU) and Jacobian mode (estimation.batch)."""

    counts: np.ndarray
    n_use: int
    use_apriori: bool
    max_iterations: int
    tolerance_lu: float
    jacobian: int


@dataclass(frozen=True, eq=False)
class FilterArrays:
    """All in filter units (LU, TU, rad). n states, C channels, K known participants, m epochs.

    layout: StateLayout; P0, Q (n, n); known_states (m, K, 6); channel_kind (C,), channel_ends (C, 4),
    channel_flags (C,), channel_mod_index / channel_mod_coeff (C, M), sigma (C,); model / model_params:
    dynamics; dt_tu, substeps: step and RK4 substeps; divergence_position_lu: health bound.
    """

    layout: StateLayout
    P0: np.ndarray
    Q: np.ndarray
    known_states: np.ndarray
    channel_kind: np.ndarray
    channel_ends: np.ndarray
    channel_flags: np.ndarray
    channel_mod_index: np.ndarray
    channel_mod_coeff: np.ndarray
    sigma: np.ndarray
    model: int
    model_params: np.ndarray
    dt_tu: float
    substeps: int
    divergence_position_lu: float
    batch: BatchArrays | None = None

    @property
    def n_gain(self) -> int:
        return self.layout.n_estimated if self.layout.has_consider else -1

    @property
    def n_nees(self) -> int:
        return self.layout.n_estimated


@dataclass(frozen=True, eq=False)
class EstimateHistory:
    """err, sigma (m, n); nees (m,); innovation, innovation_std (m, C); status 'ok' or 'diverged' with
    its reason; fail_step (-1 if ok); data_end_step: the last epoch whose measurements the estimator used
    (later epochs are a prediction; -1: all); extras: estimator-specific scalars (a batch's iterations,
    condition number, post-fit residual RMS per channel)."""

    err: np.ndarray
    sigma: np.ndarray
    nees: np.ndarray
    innovation: np.ndarray
    innovation_std: np.ndarray
    ok: bool
    reason: str
    fail_step: int
    data_end_step: int = -1
    extras: dict | None = None


def _ekf(arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    kind, start, size = arrays.layout.arrays()
    err, sigma, nees, innovation, innovation_std, status, fail_step = run_ekf(
        x0_hat, arrays.P0, arrays.Q, truth, y_obs, arrays.known_states, arrays.channel_kind, arrays.channel_ends,
        arrays.channel_flags, arrays.channel_mod_index, arrays.channel_mod_coeff, arrays.sigma, kind, start, size,
        arrays.model, arrays.model_params, arrays.dt_tu, arrays.substeps, arrays.n_gain, arrays.n_nees,
        arrays.divergence_position_lu)
    ok = status == STATUS_OK
    return EstimateHistory(err, sigma, nees, innovation, innovation_std, ok, "" if ok else STATUS_NAMES[int(status)],
                           int(fail_step))


def _batch(arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    """Batch least squares over the span, then the converged trajectory and its mapped covariance at every
    epoch. NEES is the epoch state's, e0^T P^-1 e0: to first order the same at every epoch (e_k = Phi e0,
    P_k = Phi P Phi^T), so it is reported at all of them."""
    settings = arrays.batch
    kind, start, _ = arrays.layout.arrays()
    solution, traj, phi, _ = solve_batch(
        x0_hat, arrays.P0, y_obs, arrays.known_states, arrays.channel_kind, arrays.channel_ends,
        arrays.channel_flags, arrays.channel_mod_index, arrays.channel_mod_coeff, arrays.sigma, kind, start,
        arrays.model, arrays.model_params, arrays.dt_tu, settings.counts, settings.n_use, settings.use_apriori,
        settings.max_iterations, settings.tolerance_lu, settings.jacobian)
    m, n = truth.shape
    err = traj - truth
    P = solution.P
    sigma = np.empty((m, n))
    for k in range(m):
        Pk = P.copy()
        for b, (kb, a) in enumerate(zip(kind, start)):
            if kb == BLOCK_SPACECRAFT:  # Phi_k acts on each spacecraft block: rows and columns of P
                Pk[a : a + 6, :] = phi[k, b] @ Pk[a : a + 6, :]
        for b, (kb, a) in enumerate(zip(kind, start)):
            if kb == BLOCK_SPACECRAFT:
                Pk[:, a : a + 6] = Pk[:, a : a + 6] @ phi[k, b].T
        sigma[k] = np.sqrt(np.abs(np.diag(Pk)))
    n_est = arrays.n_nees
    ok = solution.status == BATCH_OK
    if ok:
        e0 = err[0, :n_est]
        nees_value = float(e0 @ np.linalg.solve(P[:n_est, :n_est], e0))
    else:
        nees_value = np.nan
    innovation, spread = postfit_residuals(traj, phi, _block_of_start(kind, start, n), y_obs, arrays.known_states,
                                           arrays.channel_kind, arrays.channel_ends, arrays.channel_flags,
                                           arrays.channel_mod_index, arrays.channel_mod_coeff, arrays.sigma, P,
                                           settings.n_use)
    extras = {"iterations": solution.iterations, "condition": solution.condition,
              "residual_rms": solution.residual_rms, "corrections_lu": solution.corrections,
              "status": solution.status}
    return EstimateHistory(err, sigma, np.full(m, nees_value), innovation, spread, ok,
                           "" if ok else f"batch: {solution.status} after {solution.iterations} iterations",
                           -1 if ok else 0, settings.n_use - 1, extras)


def _block_of_start(kind, start, n):
    out = np.full(n, -1, dtype=np.int64)
    for b, a in enumerate(start):
        out[a] = b
    return out


ESTIMATORS = {"ekf": _ekf, "batch": _batch}


def estimator_names() -> list[str]:
    return list(ESTIMATORS)


def estimate(name: str, arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    """Run the named estimator over one run's inputs: x0_hat (n,), y_obs (m, C), truth (m, n)."""
    return ESTIMATORS[name](arrays, x0_hat, y_obs, truth)
