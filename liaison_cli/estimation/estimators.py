"""Estimators behind one interface: `estimate(name, arrays, x0_hat, y_obs, truth) -> EstimateHistory`.

`FilterArrays` is everything an estimator may use: the state layout, the a-priori and process-noise
matrices, the channels (kind, ends, flags, modifiers, sigma), the known participants' states and the
dynamics model as code + parameters. The history it returns is the same whatever the estimator: per-epoch
errors and sigmas, NEES, innovations per channel, a status and the step at which it failed.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.estimation.batch import BATCH_OK, solve_batch
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
    solution, traj, phi, innovation, spread = solve_batch(
        x0_hat, arrays.P0, y_obs, arrays.known_states, arrays.channel_kind, arrays.channel_ends,
        arrays.channel_flags, arrays.channel_mod_index, arrays.channel_mod_coeff, arrays.sigma, kind, start,
        arrays.model, arrays.model_params, arrays.dt_tu, settings.counts, settings.n_use, settings.use_apriori,
        settings.max_iterations, settings.tolerance_lu, settings.jacobian)
    m, n = truth.shape
    err = traj - truth
    P = solution.P
    # diag(Phi_k P Phi_k^T) block by block: a spacecraft block's diagonal needs only its own P_bb.
    sigma = np.tile(np.sqrt(np.abs(np.diag(P))), (m, 1))
    for b, (kb, a) in enumerate(zip(kind, start)):
        if kb == BLOCK_SPACECRAFT:
            P_bb = P[a : a + 6, a : a + 6]
            sigma[:, a : a + 6] = np.sqrt(np.abs(np.einsum("kij,jl,kil->ki", phi[:, b], P_bb, phi[:, b])))
    n_est = arrays.n_nees
    ok = solution.status == BATCH_OK
    if ok:
        e0 = err[0, :n_est]
        nees_value = float(e0 @ np.linalg.solve(P[:n_est, :n_est], e0))
    else:
        nees_value = np.nan
    extras = {"iterations": solution.iterations, "condition": solution.condition,
              "residual_rms": solution.residual_rms, "corrections_lu": solution.corrections,
              "status": solution.status}
    return EstimateHistory(err, sigma, np.full(m, nees_value), innovation, spread, ok,
                           "" if ok else f"batch: {solution.status} after {solution.iterations} iterations",
                           -1 if ok else 0, settings.n_use - 1, extras)


ESTIMATORS = {"ekf": _ekf, "batch": _batch}


def estimator_names() -> list[str]:
    return list(ESTIMATORS)


def estimate(name: str, arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    """Run the named estimator over one run's inputs: x0_hat (n,), y_obs (m, C), truth (m, n)."""
    return ESTIMATORS[name](arrays, x0_hat, y_obs, truth)
