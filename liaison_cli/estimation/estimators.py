"""Estimators behind one interface: `estimate(name, arrays, x0_hat, y_obs, truth) -> EstimateHistory`, each
described once (estimation.estimator.Estimator) and registered in ESTIMATORS.

`FilterArrays` is everything an estimator may use: the state layout, the a-priori and process-noise
matrices, the channels (kind, ends, flags, modifiers, sigma), the known participants' states and the
dynamics model as code + parameters. The history it returns is the same whatever the estimator: per-epoch
errors and sigmas, NEES, innovations per channel, a status and the step at which it failed.
"""

from dataclasses import dataclass, field

import numpy as np

from liaison_cli.compiled_calls import writable_c
from liaison_cli.estimation.batch import BATCH_OK, solve_batch
from liaison_cli.estimation.blocks import BLOCK_SPACECRAFT, StateLayout
from liaison_cli.estimation.estimator import Estimator
from liaison_cli.estimation.filter_loop import (END_RECEIVER_STATE, END_SECOND_STATE, END_TRANSMITTER_STATE,
                                                STATUS_NAMES, STATUS_OK, run_ekf, shared_calls)
from liaison_cli.estimation.kernel_args import (BlockLayout, Channels, DirectionRecord, Dynamics, EkfSettings,
                                                ProcessNoise, SmootherRecord, channels_of, direction_record,
                                                dynamics_of, process_noise_of)
from liaison_cli.estimation.process_noise import uncoupled_process_noise
from liaison_cli.estimation.initial_batch import INITIAL_BATCH_OK, InitialBatchSettings, solve_initial_batch
from liaison_cli.estimation.smoother import rts_smooth


@dataclass(frozen=True, eq=False)
class BatchArrays:
    """The batch solve's settings: counts (m - 1,) RK8 steps per interval; a window's epochs 0..n_use-1 carry
    its data, the next n_predict its prediction; a-priori information on or off; iteration limit, tolerance
    (LU) and Jacobian mode (estimation.batch); sliding windows: how many, renewal_steps epochs apart."""

    counts: np.ndarray
    n_use: int
    use_apriori: bool
    max_iterations: int
    tolerance_lu: float
    jacobian: int
    n_predict: int = 0  # prediction epochs after each window's span
    windows: int = 1
    renewal_steps: int = 0  # epochs between window starts


@dataclass(frozen=True, eq=False)
class FilterArrays:
    """All in filter units (LU, TU, rad). n states, C channels, K known participants, m epochs.

    layout: StateLayout; P0, Q (n, n); known_states (m, K, 6), or (m, K, 9) with the accelerations a
    light-time TDoA reads (measurements.tdoa); channel_kind (C,), channel_ends (C, 4), channel_flags (C,),
    channel_mod_index / channel_mod_coeff (C, M), sigma (C,); model / model_params: dynamics; dt_tu: the interval; substeps (B,): each block's integrator steps per interval
    (spacecraft blocks; scenario.integration_steps); divergence_position_lu: health bound.
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
    substeps: np.ndarray
    divergence_position_lu: float
    batch: BatchArrays | None = None
    underweight: float = 0.0  # Lear's gain underweighting (ekf.update_scalar)
    residual_gate_sigma: float = 0.0  # the EKF's residual gate, k (filter_loop.gated); 0: no gate
    residual_gate_after: int = 0  # ... applied once this many measurements have been accepted
    smoother: bool = False  # the EKF also returns its RTS-smoothed history (estimation.smoother)
    burns: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))  # filter_loop.apply_burns
    initial_batch: InitialBatchSettings | None = None  # the EKF starts from a batch solve (estimation.initial_batch)
    empirical_tau_tu: float = 0.0  # the empirical accelerations' time constant (estimation.process_noise); 0: none
    ric_noise: np.ndarray | None = None  # (B, 3, 3) RIC process-noise factors (kernel_args.ProcessNoise); None: none
    primaries: np.ndarray | None = None  # (m, 2, 6) the Earth's and the Moon's states, with ric_noise

    def channels(self) -> Channels:
        return channels_of(self.channel_kind, self.channel_ends, self.channel_flags, self.channel_mod_index,
                           self.channel_mod_coeff, self.sigma)

    def block_layout(self) -> BlockLayout:
        return BlockLayout(*self.layout.arrays())

    def dense_process_noise(self) -> np.ndarray:
        """Q (n, n) for a dense step P <- Phi P Phi' + Q: Q itself, or, with empirical-acceleration blocks, Q
        rebuilt from the reduced form the EKF's coupled step takes (process_noise.uncoupled_process_noise)."""
        if self.empirical_tau_tu == 0.0:
            return self.Q
        return uncoupled_process_noise(self.Q, self.layout.empirical_couplings(), self.empirical_tau_tu, self.dt_tu)

    def dynamics(self, t0_tu: float = 0.0) -> Dynamics:
        if len(np.atleast_1d(self.substeps)) != len(self.layout.blocks):  # the compiled loop reads one per block
            raise ValueError(f"substeps: {len(np.atleast_1d(self.substeps))} counts for "
                             f"{len(self.layout.blocks)} state blocks")
        return dynamics_of(self.model_params, self.dt_tu, self.substeps, t0_tu, self.empirical_tau_tu)

    def direction_starts(self) -> tuple[np.ndarray, np.ndarray]:
        """(spacecraft block offsets (S,), offsets of each pair of estimated spacecraft a channel links (L, 2),
        sorted): where filter_loop.record_directions looks."""
        kind, start = self.layout.arrays()[:2]
        spacecraft = start[kind == BLOCK_SPACECRAFT]
        ends = self.channel_ends
        linked = {tuple(sorted((int(a), int(b))))
                  for first, second in ((END_RECEIVER_STATE, END_TRANSMITTER_STATE),
                                        (END_SECOND_STATE, END_TRANSMITTER_STATE))  # a TDoA's second path too
                  for a, b in zip(ends[:, first], ends[:, second]) if a >= 0 and b >= 0 and a != b}
        return spacecraft, np.array(sorted(linked), dtype=np.int64).reshape(-1, 2)

    def process_noise(self, m: int) -> ProcessNoise:
        """The EKF's process noise over the last m epochs (kernel_args.ProcessNoise)."""
        if self.ric_noise is None:
            return process_noise_of(self.Q)
        return process_noise_of(self.Q, self.ric_noise, self.primaries[len(self.primaries) - m :])

    def ekf_settings(self) -> EkfSettings:
        return EkfSettings(int(self.n_gain), int(self.n_nees), float(self.divergence_position_lu),
                           float(self.underweight), float(self.residual_gate_sigma), int(self.residual_gate_after))

    @property
    def n_gain(self) -> int:
        return self.layout.n_estimated if self.layout.has_consider else -1

    @property
    def n_nees(self) -> int:
        return self.layout.n_nees


@dataclass(frozen=True, eq=False)
class EstimateHistory:
    """err, sigma (m, n); nees (m,); innovation, innovation_std (m, C); status 'ok' or 'diverged' with
    its reason; fail_step (-1 if ok); data_end_step: the last epoch whose measurements the estimator used
    (later epochs are a prediction; -1: all); extras: estimator-specific scalars (a batch's iterations,
    condition number, post-fit residual RMS per channel); rejected (m, C): measurements the EKF's residual
    gate refused (None: an estimator without a gate, nothing rejected)."""

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
    rejected: np.ndarray | None = None
    smoothed_err: np.ndarray | None = None  # (m, n) with filter.smoother: rts (NaN for a run that failed)
    smoothed_sigma: np.ndarray | None = None
    directions: DirectionRecord | None = None  # the EKF's consistency by direction (filter_loop.record_directions)


def _ekf(arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    if arrays.initial_batch is not None:
        return _ekf_from_initial_batch(arrays, x0_hat, y_obs, truth)
    return ekf_with_record(arrays, x0_hat, y_obs, truth, arrays.smoother)[0]


def ekf_with_record(arrays: FilterArrays, x0_hat, y_obs, truth, record: bool):
    """The EKF's history and, with `record`, its forward record: states (m, 2, n) = [x_hat, x_bar] and matrices
    (m, 3, n, n) = [P_bar, P, Phi] per epoch (the smoother's input; an export's estimate and covariance). From
    the a priori at t0 (an initial batch is not part of it: export refuses such a scenario)."""
    return _ekf_pass(arrays, x0_hat, arrays.P0, y_obs, truth, arrays.burns, 0.0, record)


def _ekf_covariance_record(arrays: FilterArrays, x0_hat, y_obs, truth):
    """Estimator.covariance_record of the EKF: its history, x_hat (m, n) and P (m, n, n) after each epoch's update."""
    history, states, matrices = ekf_with_record(arrays, x0_hat, y_obs, truth, True)
    return history, states[:, 0], matrices[:, 1]


def _ekf_pass(arrays: FilterArrays, x0_hat, P0, y_obs, truth, burns, t0_tu, record: bool):
    """One EKF pass over the epochs of y_obs / truth (m rows), epoch 0 at t0_tu, from (x0_hat, P0):
    (EstimateHistory, states, matrices) as ekf_with_record; the smoother runs when arrays.smoother."""
    m, n = truth.shape
    stored = m if record else 0  # the forward record: 3 (n, n) matrices per epoch
    states, matrices = np.zeros((stored, 2, n)), np.zeros((stored, 3, n, n))
    directions = direction_record(*arrays.direction_starts(), m)
    args = (int(arrays.model), x0_hat, P0, arrays.process_noise(m), truth, y_obs,
            writable_c(arrays.known_states[len(arrays.known_states) - m :]), arrays.channels(), arrays.block_layout(),
            arrays.dynamics(t0_tu), arrays.ekf_settings(), burns, SmootherRecord(states, matrices), directions,
            shared_calls(arrays.channels(), arrays.block_layout(), arrays.dynamics(t0_tu)))
    err, sigma, nees, innovation, innovation_std, rejected, status, fail_step = run_ekf(*args)
    ok = status == STATUS_OK
    smoothed_err = smoothed_sigma = None
    if arrays.smoother:
        x_s, smoothed_sigma, _ = rts_smooth(states, matrices, m - 1 if ok else -1)
        smoothed_err = x_s - truth
    return EstimateHistory(err, sigma, nees, innovation, innovation_std, ok, "" if ok else STATUS_NAMES[int(status)],
                           int(fail_step), rejected=rejected, smoothed_err=smoothed_err,
                           smoothed_sigma=smoothed_sigma, directions=directions), states, matrices


def _ekf_from_initial_batch(arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    """filter.initial_batch_hours: a batch solve over the window's epochs 0..e from the a priori, handed over
    at epoch e with its covariance (estimation.initial_batch), then the EKF on the measurements after e.
    The history: the batch's smoothed solution over the window (its NEES per epoch against the mapped
    covariance; innovations NaN there), the EKF's after. extras: the solve's iterations and post-fit
    chi-square per measurement."""
    solution = solve_initial_batch(arrays, x0_hat, y_obs)
    m, n = truth.shape
    e = solution.traj.shape[0] - 1
    extras = {"initial_batch_iterations": solution.iterations, "initial_batch_epochs": e,
              "initial_batch_chi2_per_measurement": solution.weighted_rss / max(solution.measurements, 1)}
    if solution.status != INITIAL_BATCH_OK:
        nan = np.full((m, n), np.nan)
        return EstimateHistory(nan, nan.copy(), np.full(m, np.nan), np.full(y_obs.shape, np.nan),
                               np.full(y_obs.shape, np.nan), False, f"initial batch: {solution.status}", 0,
                               extras=extras, rejected=np.zeros(y_obs.shape, dtype=bool))
    burns = arrays.burns.copy()
    burns[:, 2] -= e  # the scenario keeps manoeuvres out of the window
    after = _ekf_pass(arrays, solution.x_handover, solution.P_handover, y_obs[e:], truth[e:], burns, e * arrays.dt_tu,
                      False)[0]
    window_err = solution.traj - truth[: e + 1]
    window_nees = np.array([_epoch_nees(error, P, arrays.n_nees) for error, P in
                            zip(window_err, solution.covariance)])
    err = np.vstack([window_err[:e], after.err])
    sigma = np.vstack([solution.sigma[:e], after.sigma])
    nees = np.concatenate([window_nees[:e], after.nees])
    innovation = np.vstack([np.full((e, y_obs.shape[1]), np.nan), after.innovation])
    innovation_std = np.vstack([np.full((e, y_obs.shape[1]), np.nan), after.innovation_std])
    rejected = np.vstack([np.zeros((e, y_obs.shape[1]), dtype=bool), after.rejected])
    return EstimateHistory(err, sigma, nees, innovation, innovation_std, after.ok, after.reason,
                           after.fail_step + e if not after.ok else -1, extras=extras, rejected=rejected,
                           directions=_after_window(after.directions, e))


def _after_window(directions: DirectionRecord, e: int) -> DirectionRecord:
    """The EKF's direction record behind e NaN epochs (the initial batch's window, not resolved by direction)."""
    def padded(a):
        return np.concatenate([np.full((e, *a.shape[1:]), np.nan), a])
    return directions._replace(nees_spacecraft=padded(directions.nees_spacecraft),
                               time_shift=padded(directions.time_shift), along_pair=padded(directions.along_pair),
                               covariance=padded(directions.covariance))


def _batch(arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    return _batch_windows(arrays, x0_hat, y_obs, truth, False)[0]


def _batch_covariance_record(arrays: FilterArrays, x0_hat, y_obs, truth):
    """Estimator.covariance_record of the batch: its history, each epoch's estimate (the solution of the window
    that holds the epoch, propagated) and its covariance mapped there (Phi_k P Phi_k^T); NaN after a failure."""
    return _batch_windows(arrays, x0_hat, y_obs, truth, True)


def _batch_windows(arrays: FilterArrays, x0_hat, y_obs, truth, keep: bool):
    """(EstimateHistory, estimates (m, n), covariances (m, n, n)): the batch run; the last two only with `keep`
    (else None).

    Batch least squares in sliding windows (one window by default): window w starts at epoch w * renewal,
    solves for the state there from the span's data, and predicts past the span. Window w > 0 starts from
    the previous solution propagated to its epoch (and, with a-priori information on, its propagated
    covariance). The history at an epoch is the latest window that starts at or before it (its smoothed
    estimate inside its span, its prediction after); NEES is each window's epoch-state NEES, to first order
    the same at every epoch of its piece (e_k = Phi e0, P_k = Phi P Phi^T)."""
    settings = arrays.batch
    kind, start = arrays.layout.arrays()[:2]
    m, n = truth.shape
    err, sigma = np.full((m, n), np.nan), np.full((m, n), np.nan)
    nees = np.full(m, np.nan)
    innovation, spread = np.full(y_obs.shape, np.nan), np.full(y_obs.shape, np.nan)
    x_apriori, P_apriori = x0_hat, arrays.P0
    starts = [w * settings.renewal_steps for w in range(settings.windows)]
    windows, failure = [], ""
    estimates = np.full((m, n), np.nan) if keep else None
    covariances = np.full((m, n, n), np.nan) if keep else None
    for w, k0 in enumerate(starts):
        k1 = min(m, k0 + settings.n_use + settings.n_predict)  # this window's epochs: [k0, k1)
        piece_end = starts[w + 1] if w + 1 < len(starts) else m
        solution, traj, phi, post, post_spread = solve_batch(
            x_apriori, P_apriori, y_obs[k0:k1], arrays.known_states[k0:k1], arrays.channels(), arrays.block_layout(),
            arrays.model, arrays.dynamics(k0 * arrays.dt_tu), settings.counts[k0 : k1 - 1], settings.n_use,
            settings.use_apriori, settings.max_iterations, settings.tolerance_lu, settings.jacobian)
        e = traj - truth[k0:k1]
        s_w = _mapped_sigma(solution.P, phi, kind, start)
        ok = solution.status == BATCH_OK
        nees_value = _epoch_nees(e[0], solution.P, arrays.n_nees) if ok else np.nan
        piece = slice(0, piece_end - k0)
        err[k0:piece_end], sigma[k0:piece_end], nees[k0:piece_end] = e[piece], s_w[piece], nees_value
        if keep and ok:
            estimates[k0:piece_end] = traj[piece]
            for j in range(piece_end - k0):
                covariances[k0 + j] = _mapped_covariance(solution.P, phi[j], kind, start)
        data = slice(k0 + 1, k0 + settings.n_use)
        innovation[data], spread[data] = post[1 : settings.n_use], post_spread[1 : settings.n_use]
        ahead = e[settings.n_use : k1 - k0].reshape(-1, n)
        windows.append({"iterations": solution.iterations, "condition": solution.condition, "nees": nees_value,
                        "status": solution.status, "residual_rms": solution.residual_rms,
                        "prediction_rms_lu": _prediction_rms(ahead, kind, start)})
        if not ok:
            failure = f"batch window {w}: {solution.status} after {solution.iterations} iterations"
            break
        if w + 1 < len(starts):  # the next window starts from this solution, propagated
            step = starts[w + 1] - k0
            x_apriori = traj[step].copy()
            P_apriori = _mapped_covariance(solution.P, phi[step], kind, start) if settings.use_apriori else arrays.P0
    ok = not failure
    last = windows[-1]
    extras = {"iterations": last["iterations"], "condition": last["condition"], "residual_rms": last["residual_rms"],
              "status": last["status"], "windows": windows}
    data_end = starts[len(windows) - 1] + settings.n_use - 1
    return EstimateHistory(err, sigma, nees, innovation, spread, ok, failure, -1 if ok else starts[len(windows) - 1],
                           data_end, extras), estimates, covariances


def _mapped_sigma(P, phi, kind, start):
    """sqrt(diag(Phi_k P Phi_k^T)) (m, n): a spacecraft block's diagonal needs only its own P_bb."""
    m = phi.shape[0]
    sigma = np.tile(np.sqrt(np.abs(np.diag(P))), (m, 1))
    for b, (kb, a) in enumerate(zip(kind, start)):
        if kb == BLOCK_SPACECRAFT:
            P_bb = P[a : a + 6, a : a + 6]
            sigma[:, a : a + 6] = np.sqrt(np.abs(np.einsum("kij,jl,kil->ki", phi[:, b], P_bb, phi[:, b])))
    return sigma


def _mapped_covariance(P, phi_k, kind, start):
    """Phi_k P Phi_k^T with Phi_k (B, 6, 6) acting on the spacecraft blocks (identity elsewhere)."""
    full = np.eye(P.shape[0])
    for b, (kb, a) in enumerate(zip(kind, start)):
        if kb == BLOCK_SPACECRAFT:
            full[a : a + 6, a : a + 6] = phi_k[b]
    return full @ P @ full.T


def _epoch_nees(e0, P, n_est):
    e0 = e0[:n_est]
    return float(e0 @ np.linalg.solve(P[:n_est, :n_est], e0))


def _prediction_rms(errors_ahead, kind, start):
    """Per spacecraft block, the RMS of the 3-D position error over the prediction epochs (LU); NaN if none."""
    out = []
    for kb, a in zip(kind, start):
        if kb == BLOCK_SPACECRAFT:
            norms = np.linalg.norm(errors_ahead[:, a : a + 3], axis=1)
            out.append(float(np.sqrt(np.mean(norms**2))) if norms.size else np.nan)
    return np.array(out)


EKF = Estimator(
    name="ekf", summary="the extended Kalman filter", run=_ekf, carries_clocks=True, carries_biases=True,
    carries_manoeuvres=True, dynamics=("crtbp", "ephemeris"), smoother=True, consider=True, residual_gate=True,
    error_budget=True, initial_batch=True, process_noise=True, dynamics_parameters=True,
    covariance_record=_ekf_covariance_record, record_meaning="EKF estimate (after each epoch's update)",
    empirical_accelerations=True)
# The batch solves for the spacecraft's epoch states and constant blocks (link biases); clocks are synchronised
# apart from it by clock_sync, and it has no consider treatment (estimation.batch treats every state alike).
BATCH = Estimator(name="batch", summary="least squares (with a batch section)", run=_batch, settings_section="batch",
                  carries_biases=True, residuals="post-fit residuals", nees_per_epoch=False,
                  covariance_record=_batch_covariance_record,
                  record_meaning="batch least-squares estimate: the solution of the window holding the epoch, "
                                 "propagated (fitted to the span's data inside it, predicted after), with its "
                                 "covariance mapped by the STM")
ESTIMATORS: dict[str, Estimator] = {estimator.name: estimator for estimator in (EKF, BATCH)}
DEFAULT_ESTIMATOR = EKF.name


def estimator_names() -> list[str]:
    return list(ESTIMATORS)


def get_estimator(name: str) -> Estimator:
    try:
        return ESTIMATORS[name]
    except KeyError:
        raise ValueError(f"unknown estimator {name!r}; allowed: {', '.join(ESTIMATORS)}") from None


def estimators_that(capability: str) -> list[str]:
    """The names of the estimators whose descriptor has this capability (e.g. 'smoother'), for messages."""
    return [name for name, estimator in ESTIMATORS.items() if getattr(estimator, capability)]


def estimate(name: str, arrays: FilterArrays, x0_hat, y_obs, truth) -> EstimateHistory:
    """Run the named estimator over one run's inputs: x0_hat (n,), y_obs (m, C), truth (m, n)."""
    return ESTIMATORS[name].run(arrays, x0_hat, y_obs, truth)
