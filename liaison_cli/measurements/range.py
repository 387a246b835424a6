"""Two-way range (Turan et al. 2022, Eq. 14-17).

Truth: the light-time fixed-point iteration of Eq. 14-15 (downlink then uplink leg, averaged), solved in
the inertial frame that coincides with the rotating frame at the reception time. Filter: the
instantaneous geometric range of Eq. 17, or (flag FLAG_LIGHT_TIME) its first-order light-time form. The
difference (about -range_rate * tau, up to ~0.2 km for a lunar orbiter) is a genuine model error that a
geometric filter has to live with.
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import M_PER_LU, SPEED_OF_LIGHT_LU_TU
from liaison_cli.measurements.observable import ChannelKind, Observable
from liaison_cli.measurements.range_rate import range_rate

KIND_RANGE = 0
FLAG_LIGHT_TIME = 1  # channel flag: predict the two-way range to first order in the light time


@njit(cache=True)
def geometric_range(r_receiver, r_transponder):
    """Eq. 17: |r_receiver - r_transponder|, (3,), (3,) -> float (LU)."""
    d0 = r_receiver[0] - r_transponder[0]
    d1 = r_receiver[1] - r_transponder[1]
    d2 = r_receiver[2] - r_transponder[2]
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)


@njit(cache=True)
def geometric_range_gradient(r_receiver, r_transponder):
    """d(range)/d(r_receiver) (3,); the transponder's gradient is its negative. Velocity partials are 0."""
    rho = geometric_range(r_receiver, r_transponder)
    out = np.empty(3)
    for i in range(3):  # element loop, not an array expression (see range_rate)
        out[i] = (r_receiver[i] - r_transponder[i]) / rho
    return out


@njit(cache=True, inline="always")
def write_position_partials(g, g_receiver, g_transmitter):
    """A value that depends on r_receiver - r_transmitter only: d/d(receiver state) = [g, 0, 0, 0],
    d/d(transmitter state) = [-g, 0, 0, 0]."""
    for i in range(3):
        g_receiver[i] = g[i]
        g_transmitter[i] = -g[i]
        g_receiver[3 + i] = 0.0
        g_transmitter[3 + i] = 0.0


@njit(cache=True, inline="always")
def predict_range(x_receiver, x_transponder, flags, g_receiver, g_transponder):
    """Filter model of the two-way range (LU) from the two ends' states (6,), (6,); writes the partials
    with respect to each end's state into g_receiver, g_transponder (6,). With FLAG_LIGHT_TIME the value
    is rho - rho_dot * rho / c (Eq. 14-15 to first order); the partials stay geometric (they change by
    ~1e-6 relative)."""
    rho = geometric_range(x_receiver, x_transponder)  # reads the first three elements
    predicted = rho
    if flags & FLAG_LIGHT_TIME:
        predicted -= range_rate(x_receiver, x_transponder) * predicted / SPEED_OF_LIGHT_LU_TU
    for i in range(3):  # geometric_range_gradient, written in place
        g = (x_receiver[i] - x_transponder[i]) / rho
        g_receiver[i] = g
        g_transponder[i] = -g
        g_receiver[3 + i] = 0.0
        g_transponder[3 + i] = 0.0
    return predicted


def one_way_light_time(receiver, transmitter, tol_tu=1e-16, max_iter=20):
    """Downlink light time tau_d (m,) in TU: |r_T(t - tau_d) - r_R(t)| = c tau_d, by fixed-point iteration.
    receiver / transmitter: trajectories (`.states` (m, 6), `.inertial_position_before(dt_back_tu)`)."""
    c = SPEED_OF_LIGHT_LU_TU
    r_receiver_now = receiver.states[:, 0:3]
    tau_d = np.linalg.norm(transmitter.states[:, 0:3] - r_receiver_now, axis=1) / c
    for _ in range(max_iter):
        r_t = transmitter.inertial_position_before(tau_d)
        new = np.linalg.norm(r_t - r_receiver_now, axis=1) / c
        done = np.max(np.abs(new - tau_d)) < tol_tu
        tau_d = new
        if done:
            break
    return tau_d


def two_way_light_time_range(receiver, transponder, tol_tu=1e-16, max_iter=20):
    """Eq. 14-15: two-way range recorded by the receiver at the sample times, (m,) LU.

    Downlink: rho_d = |r_T(t - tau_d) - r_R(t)|; uplink: rho_u = |r_T(t - tau_d) - r_R(t - tau_d - tau_u)|;
    the measurement is (rho_d + rho_u) / 2.
    """
    c = SPEED_OF_LIGHT_LU_TU
    tau_d = one_way_light_time(receiver, transponder, tol_tu, max_iter)
    r_transponder = transponder.inertial_position_before(tau_d)
    tau_u = tau_d.copy()
    for _ in range(max_iter):
        r_r = receiver.inertial_position_before(tau_d + tau_u)
        new = np.linalg.norm(r_transponder - r_r, axis=1) / c
        done = np.max(np.abs(new - tau_u)) < tol_tu
        tau_u = new
        if done:
            break
    return 0.5 * c * (tau_d + tau_u)


def _simulate(code, receiver, transponder, light_time: bool):
    if light_time:
        return two_way_light_time_range(receiver, transponder)
    return np.linalg.norm(receiver.states[:, 0:3] - transponder.states[:, 0:3], axis=1)


def range_sigma(noise, receiver):
    """The ranging sigma (noise.sigma_m or the link budget), in LU: shared by every range-like observable."""
    return (noise.resolved_sigma_m() / M_PER_LU,)


def light_time_flags(filter_spec) -> int:
    """filter.range_model: light_time -> FLAG_LIGHT_TIME for every range-like observable."""
    return FLAG_LIGHT_TIME if filter_spec.range_model == "light_time" else 0


OBSERVABLE = Observable(
    name="range",
    channels=(ChannelKind(KIND_RANGE, "range", "m", M_PER_LU),),
    sigma=range_sigma,
    simulate=_simulate,
    takes_range_bias=True,
    filter_flags=light_time_flags,
    description="two-way range through a transponder (Eq. 14-17); sigma: noise.sigma_m or the link budget",
)
