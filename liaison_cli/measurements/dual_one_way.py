"""Dual one-way ranging (002 Eq. 1-4): each end times the other's signal against its own clock.

Link ends i (the link's receiver) and j (its transponder, here a second transmitter-receiver):
  rho_ij = |r_j(t - tau_ij) - r_i(t)| + c (dt_i - dt_j)     (timed by i, Eq. 1)
  rho_ji = |r_i(t - tau_ji) - r_j(t)| + c (dt_j - dt_i)     (timed by j, Eq. 2)
Two scenario observables:
- `dual_one_way`: both raw pseudoranges, clocks of both ends as modifiers (coefficients +1 / -1 and
  -1 / +1); for a filter that carries clock states.
- `dual_one_way_derived`: their mean, the range (Eq. 3, clocks cancel), and their half difference, the
  clock offset c (dt_i - dt_j) (Eq. 4; its geometric part is zero without light time). With the two
  pseudoranges' errors independent and of equal sigma, both derived channels have sigma / sqrt(2) and
  are uncorrelated.
Sigma: noise.sigma_m is the one-way pseudorange sigma (what the DLL model of radio.dual_one_way gives).
The filter's predictions use predict_pseudorange in both directions (instantaneous, or the first-order
light-time form with filter.range_model: light_time). Range-rate from the two carriers is the mean of the
two one-way Dopplers, whose clock-frequency terms cancel: the `range_rate` observable.
"""

import math

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import M_PER_LU
from liaison_cli.measurements.observable import ChannelKind, Observable
from liaison_cli.measurements.pseudorange import predict_pseudorange
from liaison_cli.measurements.range import light_time_flags, one_way_light_time, range_sigma

KIND_PSEUDORANGE_IJ = 5
KIND_PSEUDORANGE_JI = 6
KIND_DUAL_RANGE = 7
KIND_CLOCK_OFFSET = 8


@njit(cache=True, inline="always")
def predict_dual_one_way(kind, x_i, x_j, flags, g_i, g_j):
    """Geometric part (LU) of a dual one-way channel from the ends' states (6,) each, partials into g_i, g_j."""
    if kind == KIND_PSEUDORANGE_IJ:
        return predict_pseudorange(x_i, x_j, flags, g_i, g_j)
    if kind == KIND_PSEUDORANGE_JI:
        return predict_pseudorange(x_j, x_i, flags, g_j, g_i)
    gi_a = np.empty(6)
    gj_a = np.empty(6)
    gi_b = np.empty(6)
    gj_b = np.empty(6)
    forward = predict_pseudorange(x_i, x_j, flags, gi_a, gj_a)
    backward = predict_pseudorange(x_j, x_i, flags, gj_b, gi_b)
    sign = 1.0 if kind == KIND_DUAL_RANGE else -1.0
    for k in range(6):
        g_i[k] = 0.5 * (gi_a[k] + sign * gi_b[k])
        g_j[k] = 0.5 * (gj_a[k] + sign * gj_b[k])
    return 0.5 * (forward + sign * backward)


def _one_way(timer, sender, light_time: bool):
    if not light_time:
        return np.linalg.norm(timer.states[:, 0:3] - sender.states[:, 0:3], axis=1)
    tau = one_way_light_time(timer, sender)
    return np.linalg.norm(sender.inertial_position_before(tau) - timer.states[:, 0:3], axis=1)


def _simulate(code, end_i, end_j, light_time: bool):
    forward, backward = _one_way(end_i, end_j, light_time), _one_way(end_j, end_i, light_time)
    return {KIND_PSEUDORANGE_IJ: forward, KIND_PSEUDORANGE_JI: backward, KIND_DUAL_RANGE: 0.5 * (forward + backward),
            KIND_CLOCK_OFFSET: 0.5 * (forward - backward)}[code]


def _derived_sigma(noise, receiver):
    sigma = range_sigma(noise, receiver)[0] / math.sqrt(2.0)
    return (sigma, sigma)


def _raw_sigma(noise, receiver):
    sigma = range_sigma(noise, receiver)[0]
    return (sigma, sigma)


RAW = Observable(
    name="dual_one_way",
    channels=(ChannelKind(KIND_PSEUDORANGE_IJ, "pseudorange_ij", "m", M_PER_LU),
              ChannelKind(KIND_PSEUDORANGE_JI, "pseudorange_ji", "m", M_PER_LU)),
    sigma=_raw_sigma,
    simulate=_simulate,
    takes_range_bias=True,
    clock_coefficients=((1.0, -1.0), (-1.0, 1.0)),
    needs_both_clocks=True,
    filter_flags=light_time_flags,
    description="dual one-way: both pseudoranges (002 Eq. 1-2), clocks of both ends estimated; "
                "sigma: noise.sigma_m per pseudorange",
)

DERIVED = Observable(
    name="dual_one_way_derived",
    channels=(ChannelKind(KIND_DUAL_RANGE, "range", "m", M_PER_LU),
              ChannelKind(KIND_CLOCK_OFFSET, "clock_offset", "m", M_PER_LU)),
    sigma=_derived_sigma,
    simulate=_simulate,
    takes_range_bias=False,  # a common delay would add to the mean only: not modelled here
    clock_coefficients=((0.0, 0.0), (1.0, -1.0)),
    needs_both_clocks=True,
    clock_offset_channel=1,
    filter_flags=light_time_flags,
    description="dual one-way, derived: range = mean and clock offset = half difference of the two "
                "pseudoranges (002 Eq. 3-4); sigma: noise.sigma_m / sqrt(2) each",
)
