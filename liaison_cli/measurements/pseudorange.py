"""One-way pseudorange with clocks (002 Eq. 1-3 form): the receiver times a signal sent by the transmitter.

rho = |r_T(t - tau) - r_R(t)| + c (dt_R(t) - dt_T(t - tau)), tau the downlink light time. The clock
terms enter as modifiers on the channel (coefficient +1 for the receiver's clock phase, -1 for the
transmitter's, both in range units), so the geometric part here is all this file computes. Truth:
light-time solved (measurement.light_time) or instantaneous. Filter: the instantaneous geometry, or with
FLAG_LIGHT_TIME (filter.range_model: light_time) to first order in the light time,
rho + u . v_T,inertial * rho / c, with u = (r_R - r_T) / rho and v_T,inertial = v_T + z x r_T the
transmitter's velocity in the inertial frame aligned with the rotating frame (which turns at 1 rad/TU).
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import M_PER_LU, SPEED_OF_LIGHT_LU_TU
from liaison_cli.measurements.observable import ChannelKind, Observable
from liaison_cli.measurements.range import (
    FLAG_LIGHT_TIME,
    geometric_range,
    geometric_range_gradient,
    light_time_flags,
    one_way_light_time,
    range_sigma,
    write_position_partials,
)

KIND_PSEUDORANGE = 4


@njit(cache=True, inline="always")
def predict_pseudorange(x_receiver, x_transmitter, flags, g_receiver, g_transmitter):
    """Geometric part of the pseudorange (LU) and its partials with respect to both ends' states.

    The light-time term u . v_T,in * rho / c equals d . v_T,in / c with d = r_R - r_T, so its partials are
    exact and short: v_T,in / c for r_R, (-v_T,in + d x z-hat terms) / c for r_T, d / c for v_T."""
    g = geometric_range_gradient(x_receiver[0:3], x_transmitter[0:3])
    write_position_partials(g, g_receiver, g_transmitter)
    rho = geometric_range(x_receiver[0:3], x_transmitter[0:3])
    if flags & FLAG_LIGHT_TIME:
        c = SPEED_OF_LIGHT_LU_TU
        vx = x_transmitter[3] - x_transmitter[1]  # v_T + z x r_T
        vy = x_transmitter[4] + x_transmitter[0]
        vz = x_transmitter[5]
        dx = x_receiver[0] - x_transmitter[0]
        dy = x_receiver[1] - x_transmitter[1]
        dz = x_receiver[2] - x_transmitter[2]
        rho += (dx * vx + dy * vy + dz * vz) / c
        g_receiver[0] += vx / c
        g_receiver[1] += vy / c
        g_receiver[2] += vz / c
        g_transmitter[0] += (-vx + dy) / c  # d(vy)/d(x_T) = +1
        g_transmitter[1] += (-vy - dx) / c  # d(vx)/d(y_T) = -1
        g_transmitter[2] += -vz / c
        g_transmitter[3] += dx / c
        g_transmitter[4] += dy / c
        g_transmitter[5] += dz / c
    return rho


def _simulate(code, receiver, transmitter, light_time: bool):
    if not light_time:
        return np.linalg.norm(receiver.states[:, 0:3] - transmitter.states[:, 0:3], axis=1)
    tau = one_way_light_time(receiver, transmitter)
    return np.linalg.norm(transmitter.inertial_position_before(tau) - receiver.states[:, 0:3], axis=1)


OBSERVABLE = Observable(
    name="pseudorange",
    channels=(ChannelKind(KIND_PSEUDORANGE, "pseudorange", "m", M_PER_LU),),
    sigma=range_sigma,
    simulate=_simulate,
    takes_range_bias=True,
    clock_coefficients=(1.0, -1.0),
    needs_receiver_clock=True,
    filter_flags=light_time_flags,
    description="one-way pseudorange timed by the receiver's clock; sigma: noise.sigma_m (as range)",
)
