"""The filter's integration step chosen by accuracy (issue 50 item 1): substeps per measurement interval, per
spacecraft, from the one-step error of the filter's own propagator along the nominal trajectory.

The filter propagates each spacecraft over one measurement interval by `substeps` fixed steps of its model's
integrator (dynamics.model.propagate_state_stm_into: RK4 for the CRTBP, RK8 for the dated model). The step the
orbit needs depends on the orbit, not on the data rate: a 100 km lunar orbit at 600 s with 4 RK4 substeps is
metres off after one interval, a halo orbit at the same step well under a micrometre. So:

- one_step_errors: at sampled epochs of the nominal trajectory, the state after one interval by `substeps`
  steps and by twice as many; their difference over (1 - 2^-p) (p the integrator's order) is the Richardson
  estimate of the error of `substeps` steps against the exact flow of the same model: position (LU) and
  velocity (LU/TU) norms per sample.
- choose_substeps: substeps, not below MIN_SUBSTEPS, whose largest estimated error over the samples meets the
  tolerance (position error <= tolerance, velocity error x interval <= tolerance), from SUBSTEP_LADDER: each try
  takes the count the error's p-th power law predicts, raised by SAFETY and rounded up the ladder, so a choice
  takes two or three tries and lands at most about 20 % (plus the rounding) above the fewest that would do.

The tolerance is a position error per interval (filter.integration_tolerance_m, DEFAULT_TOLERANCE_M); how it
compares with the filter's covariance (the whitened one-step error in sigma) is measured in docs/model.md.
"""

from dataclasses import dataclass

import numpy as np
from numba import njit

from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.ephemeris_dynamics import SENSITIVITY_SIZE, STM_SIZE
from liaison_cli.dynamics.model import propagate_state_stm_into

# Never fewer than 4 substeps: the fixed count before issue 50, so the orbits it was accurate for (halo, NRHO
# apolune, the shipped lunar orbiters) keep their numbers to the last digit.
MIN_SUBSTEPS = 4
SUBSTEP_LADDER = (4, 5, 6, 8, 10, 12, 16, 20, 24, 32, 40, 48, 64, 80, 96, 128, 160, 192, 256)
DEFAULT_TOLERANCE_M = 1e-4
MAX_SAMPLES = 4000  # epochs sampled along the trajectory (every one when there are fewer)
# A predicted count is raised by this factor before rounding up the ladder: the estimate's power law is
# asymptotic, and one more try costs more than a slightly larger count.
SAFETY = 1.2
UNREACHABLE = -1  # StepChoice.accurate_substeps of a fixed count that even the ladder's top cannot bring in


@njit(cache=True)
def one_step_errors(model, params, states, samples, dt_tu, substeps, order):
    """Richardson estimate of the one-interval error of `substeps` steps, from states[k] (6,) at t = k dt_tu for
    each k of samples (K,): (K, 2) [position norm (LU), velocity norm (LU/TU)] of (x_s - x_2s) / (1 - 2^-order)."""
    out = np.empty((samples.shape[0], 2))
    y_coarse, y_fine = np.empty(SENSITIVITY_SIZE), np.empty(SENSITIVITY_SIZE)
    work = np.empty((5, STM_SIZE))
    state = np.empty(6)
    factor = 1.0 / (1.0 - 2.0 ** (-order))
    for i in range(samples.shape[0]):
        k = samples[i]
        for j in range(6):
            state[j] = states[k, j]
        t_tu = k * dt_tu
        propagate_state_stm_into(model, params, state, t_tu, dt_tu, substeps, y_coarse, work)
        propagate_state_stm_into(model, params, state, t_tu, dt_tu, 2 * substeps, y_fine, work)
        position, velocity = 0.0, 0.0
        for j in range(3):
            position += (y_coarse[j] - y_fine[j]) ** 2
            velocity += (y_coarse[3 + j] - y_fine[3 + j]) ** 2
        out[i, 0] = factor * np.sqrt(position)
        out[i, 1] = factor * np.sqrt(velocity)
    return out


@dataclass(frozen=True)
class StepChoice:
    """One spacecraft's integration step: substeps per interval; error_lu, the largest estimated position-
    equivalent one-step error over the samples at that count (position error, or velocity error x interval, LU);
    met: whether it is within the tolerance (False only at the ladder's top); source: 'auto' or the key that set
    it; accurate_substeps: for a count the key fixed that misses the tolerance, the fewest counts above it that
    meet it (campaign.advice names the key then); 0 otherwise."""

    substeps: int
    error_lu: float
    met: bool
    source: str = "auto"
    accurate_substeps: int = 0  # a fixed count short of the tolerance: a count that meets it (UNREACHABLE: none
    # up to the ladder's top); else 0


def sample_epochs(m: int) -> np.ndarray:
    """Epochs 0 .. m - 2 (each starts an interval), at most MAX_SAMPLES of them, evenly strided."""
    stride = max(1, -(-(m - 1) // MAX_SAMPLES))
    return np.arange(0, m - 1, stride, dtype=np.int64)


def worst_error_lu(model: int, params, states, dt_tu: float, substeps: int, order: int, samples) -> float:
    """The largest position-equivalent one-step error (position, or velocity x interval) over the samples, LU."""
    states = writable_c(states)  # one compiled signature: a read-only array is another
    errors = one_step_errors(np.int64(model), params, states, samples, float(dt_tu), np.int64(substeps),
                             np.int64(order))
    return float(np.max(np.maximum(errors[:, 0], errors[:, 1] * abs(dt_tu)))) if len(errors) else 0.0


def choose_substeps(model: int, params, states, dt_tu: float, order: int, tolerance_lu: float,
                    minimum: int = MIN_SUBSTEPS) -> StepChoice:
    """`minimum`, or the ladder count above it that the power law predicts (module docstring), whose worst
    one-step error along states (m, 6), the nominal trajectory sampled at the measurement epochs, is within
    tolerance_lu; at the ladder's top, whether or not it meets it (StepChoice.met)."""
    params = np.ascontiguousarray(params, dtype=np.float64)
    states = np.ascontiguousarray(states, dtype=np.float64)
    samples = sample_epochs(states.shape[0])
    substeps = int(minimum)
    while True:
        error = worst_error_lu(model, params, states, dt_tu, substeps, order, samples)
        if error <= tolerance_lu:
            return StepChoice(substeps, error, True)
        if substeps >= SUBSTEP_LADDER[-1]:
            return StepChoice(substeps, error, False)
        needed = substeps * SAFETY * (error / tolerance_lu) ** (1.0 / order)
        substeps = next((s for s in SUBSTEP_LADDER if s >= needed and s > substeps), SUBSTEP_LADDER[-1])
