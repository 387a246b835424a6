"""Named groups of arrays the compiled kernels take, instead of long positional lists (numba compiles
namedtuples of arrays and scalars as typed records, and unpacks them for free).

- Channels: the measurement channels' tables, C channels, M modifiers each: kind (C,) registry codes, ends
  (C, 6) see filter_loop.END_*, flags (C,), mod_index / mod_coeff (C, M) additive modifiers
  value += coeff * x[index] (-1: none), sigma (C,) 1-sigma in filter units;
- BlockLayout: the state's blocks, kind / start / size (B,) and parameter (B,): a spacecraft block's
  dynamics-parameter block start (-1: none), an empirical-acceleration block's spacecraft block start, -1 for
  every other block (estimation.blocks.StateLayout.arrays);
- Dynamics: the model's parameter vector, the measurement interval dt_tu, the filter's propagation
  substeps per interval of each block (B,) (a spacecraft block's; scenario.integration_steps), t0_tu, the time of epoch 0 from the model's origin, and empirical_tau_tu, the time
  constant of the empirical-acceleration blocks (0: none; estimation.process_noise) (the model code itself goes
  first, on its own: read at run time, dynamics.model.propagate_state_stm_into);
- EkfSettings: n_gain (states from it on are consider parameters, -1: none), n_nees (states the NEES
  covers), divergence_position_lu, underweight (Lear's beta), gate_sigma / gate_after (the residual gate);
- ProcessNoise: the fixed Q (n, n) added at every step, and the radial / in-track / cross-track PSDs of the
  spacecraft that give theirs in that frame: ric (B, 3, 3), per block and RIC axis its [position, cross,
  velocity] variance factors over one step (zero rows: none), and primaries (m, 2, 6), the Earth's and the
  Moon's states at each epoch in the filter's frame, about the nearer of which the frame is taken (length 0:
  no RIC noise in the scenario; filter_loop.step_process_noise);
- SmootherRecord: the EKF's forward record for the RTS smoother, states (m, 2, n) and matrices (m, 3, n, n)
  (length 0: not recorded);
- SharedCalls: the time update, the measurement row and the covariance prediction, which the estimators call by
  address (compiled_calls.SharedCall, built by filter_loop.shared_calls);
- DirectionRecord: the EKF's consistency by direction (filter_loop.record_directions): per-spacecraft NEES,
  the common time shift, the line of sight of each linked pair.
Field types are fixed by the builders (int64 / float64), so every scenario reuses one compiled signature.
"""

from collections import namedtuple

import numpy as np

from liaison_cli.compiled_calls import writable_c

Channels = namedtuple("Channels", ["kind", "ends", "flags", "mod_index", "mod_coeff", "sigma"])
BlockLayout = namedtuple("BlockLayout", ["kind", "start", "size", "parameter"])
Dynamics = namedtuple("Dynamics", ["params", "dt_tu", "substeps", "t0_tu", "empirical_tau_tu"])
EkfSettings = namedtuple("EkfSettings", ["n_gain", "n_nees", "divergence_position_lu", "underweight", "gate_sigma",
                                         "gate_after"])
ProcessNoise = namedtuple("ProcessNoise", ["Q", "ric", "primaries"])
SmootherRecord = namedtuple("SmootherRecord", ["states", "matrices"])
# The EKF loop's scratch, allocated once per run (filter_loop.scratch_buffers): x_bar, dx, dx_spare, e, H, h, K (n,);
# P_spare, Phi (n, n); the three ends' partials (6,); the STM propagation's y (PROPAGATION_SIZE,) and work
# (5, STM_SIZE); the covariance step's work_block (6, 6); the NEES's work_nees (n_nees, n_nees) and z_nees
# (n_nees,); the direction record's work6 (6, 6), z6 (6,), u, v (n,).
Buffers = namedtuple("Buffers", ["x_bar", "dx", "dx_spare", "e", "H", "h", "K", "P_spare", "Phi", "g_receiver",
                                 "g_transmitter", "g_second", "y_stm", "work_stm", "work_block", "work_nees", "z_nees",
                                 "work6", "z6", "u", "v"])
# Compiled functions an estimator's body calls by address (compiled_calls.SharedCall; filter_loop.shared_calls):
# the time update, the measurement row and the covariance prediction, one cached copy for every estimator.
SharedCalls = namedtuple("SharedCalls", ["time_update", "measurement_row", "predict_covariance"])
DirectionRecord = namedtuple("DirectionRecord", ["spacecraft_starts", "pair_starts", "nees_spacecraft", "time_shift",
                                                 "along_pair", "covariance", "stride"])
# The direction record samples every stride-th epoch, stride chosen so that a run keeps at most this many: its
# statistics are means over the settled epochs, whose errors are correlated over many steps, and recording
# every epoch of eml2_lunar (4,609) cost 17 % of the EKF's time.
MAX_DIRECTION_SAMPLES = 1000


def direction_record(spacecraft_starts, pair_starts, m: int) -> DirectionRecord:
    """Room for filter_loop.record_directions over m epochs: spacecraft_starts (S,) the 6-state blocks' offsets,
    pair_starts (L, 2) two such offsets per linked pair; nees_spacecraft (m, S), time_shift (m, 2) and
    along_pair (m, L, 2), covariance (m, S, 12) (each spacecraft's position and velocity blocks), NaN except at
    the sampled epochs (every stride-th, from epoch 0)."""
    starts = np.ascontiguousarray(spacecraft_starts, dtype=np.int64)
    pairs = np.ascontiguousarray(np.reshape(pair_starts, (-1, 2)), dtype=np.int64)
    stride = max(1, -(-m // MAX_DIRECTION_SAMPLES))
    return DirectionRecord(starts, pairs, np.full((m, starts.shape[0]), np.nan), np.full((m, 2), np.nan),
                           np.full((m, pairs.shape[0], 2), np.nan), np.full((m, starts.shape[0], 12), np.nan),
                           int(stride))


def channels_of(kind, ends, flags, mod_index, mod_coeff, sigma) -> Channels:
    return Channels(np.ascontiguousarray(kind, dtype=np.int64), np.ascontiguousarray(ends, dtype=np.int64),
                    np.ascontiguousarray(flags, dtype=np.int64), np.ascontiguousarray(mod_index, dtype=np.int64),
                    np.ascontiguousarray(mod_coeff, dtype=np.float64), np.ascontiguousarray(sigma, dtype=np.float64))


def dynamics_of(params, dt_tu: float, substeps, t0_tu: float = 0.0, empirical_tau_tu: float = 0.0) -> Dynamics:
    """substeps: (B,) per block of the layout."""
    return Dynamics(np.ascontiguousarray(params, dtype=np.float64), float(dt_tu),
                    np.ascontiguousarray(np.atleast_1d(substeps), dtype=np.int64), float(t0_tu),
                    float(empirical_tau_tu))


def process_noise_of(Q, ric=None, primaries=None) -> ProcessNoise:
    """ProcessNoise with the fixed Q alone when ric / primaries are None (no RIC noise)."""
    n_blocks = 0 if ric is None else len(ric)
    return ProcessNoise(writable_c(Q),
                        np.zeros((n_blocks, 3, 3)) if ric is None else np.ascontiguousarray(ric, dtype=np.float64),
                        np.zeros((0, 2, 6)) if primaries is None else np.ascontiguousarray(primaries, dtype=np.float64))
