"""Estimators behind one interface: `estimate(name, arrays, x0_hat, y_obs, truth) -> EstimateHistory`.

`FilterArrays` is everything an estimator may use: the state layout, the a-priori and process-noise
matrices, the channels (kind, ends, flags, modifiers, sigma), the known participants' states and the
dynamics model as code + parameters. The history it returns is the same whatever the estimator: per-epoch
errors and sigmas, NEES, innovations per channel, a status and the step at which it failed.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.estimation.blocks import StateLayout
from liaison_cli.estimation.filter_loop import STATUS_NAMES, STATUS_OK, run_ekf


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

    @property
    def n_gain(self) -> int:
        return self.layout.n_estimated if self.layout.has_consider else -1

    @property
    def n_nees(self) -> int:
        return self.layout.n_estimated


@dataclass(frozen=True, eq=False)
class EstimateHistory:
    """err, sigma (m, n); nees (m,); innovation, innovation_std (m, C); status 'ok' or 'diverged' with
    its reason; fail_step (-1 if ok)."""

    err: np.ndarray
    sigma: np.ndarray
    nees: np.ndarray
    innovation: np.ndarray
    innovation_std: np.ndarray
    ok: bool
    reason: str
    fail_step: int


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


ESTIMATORS = {"ekf": _ekf}


def estimator_names() -> list[str]:
    return list(ESTIMATORS)


def estimate(name: str, arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    """Run the named estimator over one run's inputs: x0_hat (n,), y_obs (m, C), truth (m, n)."""
    return ESTIMATORS[name](arrays, x0_hat, y_obs, truth)
