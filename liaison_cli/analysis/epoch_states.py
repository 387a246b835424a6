"""One run's per-epoch state table (states.parquet, scenario key output.epoch_states_runs): per spacecraft and
sampled epoch, the estimate, its error and the filter's sigma along the model's axes and along radial /
in-track / cross-track, and the correlations within the position and within the velocity block.

The rows are the epochs the caller gives: the ones at which the EKF records its covariance blocks
(estimation.kernel_args.direction_record: at most MAX_DIRECTION_SAMPLES a run; campaign.engine.worker picks them). The RIC axes are
analysis.ric's (from the true state relative to the nearer primary), so the table's RIC errors average to the
run summary's rms_{axis}_... columns over the same epochs. The radial / in-track / cross-track sigma is
sqrt(u' P u) of the spacecraft's 3 x 3 block; the axis sigmas come from the filter's diagonal at every epoch,
so an estimator without a covariance record (the batch) still has them, with NaN RIC sigmas and correlations.
"""

import numpy as np

from liaison_cli.analysis.ric import AXES, ric_axes

_MODEL_AXES = ("x", "y", "z")
# Position and velocity half of a 12-number covariance record: xx, yy, zz, xy, xz, yz.
_PAIRS = ((0, 1, 3), (0, 2, 4), (1, 2, 5))


def sampled_epochs(m: int, stride: int) -> np.ndarray:
    """The rows the table keeps: 0, stride, 2 stride, ... below m."""
    return np.arange(0, m, max(int(stride), 1))


def epoch_state_columns(rows, err, sigma, truth, covariance, primaries, primary_velocities, spacecraft,
                        to_m: float, to_m_s: float, float_dtype="float32") -> dict:
    """Columns (name -> array) of the rows (r,) x spacecraft (S), row-major by epoch: spacecraft, the estimate
    (x_km ... vz_km_s, float64: a float32 position is 30 m coarse at the Moon's distance), error_{axis}_m /
    error_v{axis}_m_s and sigma_... along the model's axes, error_/sigma_{radial,intrack,crosstrack}_m and
    _m_s, corr_{xy,xz,yz} and corr_v{xy,xz,yz}. err, sigma, truth (m, >= 6 S) in LU and LU/TU (err = estimate -
    truth); covariance (m, S, 12) or None; primaries, primary_velocities (m, 2, 3) as analysis.ric."""
    rows = np.asarray(rows, dtype=np.int64)
    n_sc = len(spacecraft)
    per_sc = [_one_spacecraft(rows, s, err, sigma, truth, covariance, primaries, primary_velocities, to_m, to_m_s)
              for s in range(n_sc)]
    columns = {"spacecraft": np.tile(np.array(spacecraft, dtype=object), len(rows))}
    for name in per_sc[0]:
        stacked = np.stack([own[name] for own in per_sc], axis=1).reshape(-1)  # (r, S) -> epoch-major
        columns[name] = stacked if name.endswith(("_km", "_km_s")) else stacked.astype(float_dtype)
    return columns


def _one_spacecraft(rows, s, err, sigma, truth, covariance, primaries, primary_velocities, to_m, to_m_s) -> dict:
    a = 6 * s
    true = truth[rows, a : a + 6]
    error = err[rows, a : a + 6]
    spread = sigma[rows, a : a + 6]
    estimate = true + error
    out = {}
    for i, axis in enumerate(_MODEL_AXES):
        out[f"{axis}_km"] = estimate[:, i] * to_m / 1e3
    for i, axis in enumerate(_MODEL_AXES):
        out[f"v{axis}_km_s"] = estimate[:, 3 + i] * to_m_s / 1e3
    for half, (prefix, unit, scale) in enumerate((("", "m", to_m), ("v", "m_s", to_m_s))):
        for i, axis in enumerate(_MODEL_AXES):
            out[f"error_{prefix}{axis}_{unit}"] = error[:, 3 * half + i] * scale
            out[f"sigma_{prefix}{axis}_{unit}"] = spread[:, 3 * half + i] * scale
    axes = ric_axes(true[:, :3], true[:, 3:], primaries[rows], primary_velocities[rows])  # (r, 3, 3) rows R, I, C
    blocks = (np.full((len(rows), 12), np.nan) if covariance is None else covariance[rows, s])
    for half, (prefix, unit, scale) in enumerate((("", "m", to_m), ("v", "m_s", to_m_s))):
        vector = error[:, 3 * half : 3 * half + 3]
        matrix = _block(blocks[:, 6 * half : 6 * half + 6])
        along = np.einsum("rij,rj->ri", axes, vector)
        variance = np.einsum("rij,rjk,rik->ri", axes, matrix, axes)
        kind = "position" if half == 0 else "velocity"
        for i, axis in enumerate(AXES):
            out[f"error_{axis}_{kind}_{unit}"] = along[:, i] * scale
            out[f"sigma_{axis}_{kind}_{unit}"] = np.sqrt(variance[:, i]) * scale
        diagonal = blocks[:, 6 * half : 6 * half + 3]
        for i, j, k in _PAIRS:
            with np.errstate(invalid="ignore", divide="ignore"):
                out[f"corr_{prefix}{_MODEL_AXES[i]}{_MODEL_AXES[j]}"] = (
                    blocks[:, 6 * half + k] / np.sqrt(diagonal[:, i] * diagonal[:, j]))
    return out


def _block(six) -> np.ndarray:
    """(r, 3, 3) symmetric matrices from (r, 6) records xx, yy, zz, xy, xz, yz."""
    matrix = np.empty((len(six), 3, 3))
    for i in range(3):
        matrix[:, i, i] = six[:, i]
    for i, j, k in _PAIRS:
        matrix[:, i, j] = matrix[:, j, i] = six[:, k]
    return matrix
