"""Process noise per radial / in-track / cross-track axis (process_noise_psd_ric_m2_s3), compiled: the step's Q
in the frame of the estimate, which moves, so it is rebuilt at every step of the EKF (filter_loop.run_ekf).

The frame is analysis.ric's: about the nearer primary, R along the relative position, C along r x v, I = C x R
(a CRTBP state's velocity is the rotating frame's, the primaries at rest; a dated one's geocentric ICRF).
"""

import numpy as np
from numba import njit

from liaison_cli.estimation.blocks import BLOCK_SPACECRAFT


@njit(cache=True)  # a call, not inlined: compiled once for every scenario combination (run_ekf skips it without RIC)
def step_process_noise(noise, Q_work, x_hat, k, block_kind, block_start, axes):
    """The process noise of the step after epoch k: noise.Q when no spacecraft gives its PSD in the radial /
    in-track / cross-track frame, else noise.Q copied into Q_work (n, n) plus, for each such spacecraft block,
    sum over the axes u of its factors (noise.ric[b, a] = q_a [dt^3/3, dt^2/2, dt] in the state's units) times
    u u' on the position, cross and velocity blocks, u the axes of the frame at the estimate x_hat (n,) about
    the nearer primary at epoch k (_ric_axes_into; axes (3, 3) scratch). The frame moves with the estimate, so
    the matrix is rebuilt at every step."""
    Q, ric, primaries = noise.Q, noise.ric, noise.primaries
    if primaries.shape[0] == 0:
        return Q
    n = Q.shape[0]
    for i in range(n):
        for j in range(n):
            Q_work[i, j] = Q[i, j]
    for b in range(block_kind.shape[0]):
        if block_kind[b] != BLOCK_SPACECRAFT or (ric[b, 0, 2] == 0.0 and ric[b, 1, 2] == 0.0 and ric[b, 2, 2] == 0.0):
            continue
        s = block_start[b]
        _ric_axes_into(x_hat, s, primaries[k], axes)
        for a in range(3):
            for i in range(3):
                for j in range(3):
                    uu = axes[a, i] * axes[a, j]
                    Q_work[s + i, s + j] += ric[b, a, 0] * uu
                    Q_work[s + i, s + 3 + j] += ric[b, a, 1] * uu
                    Q_work[s + 3 + i, s + j] += ric[b, a, 1] * uu
                    Q_work[s + 3 + i, s + 3 + j] += ric[b, a, 2] * uu
    return Q_work


@njit(cache=True, inline="always")
def _ric_axes_into(x, s, primaries_k, axes):
    """Rows R, I, C of the frame of the spacecraft state x[s : s + 6] about the nearer of the two primaries
    (primaries_k (2, 6): positions and velocities), as analysis.ric defines it: R along the relative position,
    C along r x v, I = C x R; the model's own axes where r x v vanishes (no plane to define the frame)."""
    nearer, best = 0, np.inf
    for p in range(2):
        d = 0.0
        for i in range(3):
            d += (x[s + i] - primaries_k[p, i]) ** 2
        if d < best:
            nearer, best = p, d
    r0, r1, r2 = (x[s] - primaries_k[nearer, 0], x[s + 1] - primaries_k[nearer, 1], x[s + 2] - primaries_k[nearer, 2])
    v0, v1, v2 = (x[s + 3] - primaries_k[nearer, 3], x[s + 4] - primaries_k[nearer, 4],
                  x[s + 5] - primaries_k[nearer, 5])
    c0, c1, c2 = r1 * v2 - r2 * v1, r2 * v0 - r0 * v2, r0 * v1 - r1 * v0
    r_norm, c_norm = np.sqrt(r0 * r0 + r1 * r1 + r2 * r2), np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    if not (c_norm > 0.0 and r_norm > 0.0):  # radial motion (or a state at the primary): no frame; the model's axes
        for i in range(3):
            for j in range(3):
                axes[i, j] = 1.0 if i == j else 0.0
        return
    axes[0, 0], axes[0, 1], axes[0, 2] = r0 / r_norm, r1 / r_norm, r2 / r_norm
    axes[2, 0], axes[2, 1], axes[2, 2] = c0 / c_norm, c1 / c_norm, c2 / c_norm
    axes[1, 0] = axes[2, 1] * axes[0, 2] - axes[2, 2] * axes[0, 1]
    axes[1, 1] = axes[2, 2] * axes[0, 0] - axes[2, 0] * axes[0, 2]
    axes[1, 2] = axes[2, 0] * axes[0, 1] - axes[2, 1] * axes[0, 0]
