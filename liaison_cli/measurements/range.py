"""Two-way crosslink range (Turan et al. 2022, Eq. 14-17).

Truth: the light-time fixed-point iteration of Eq. 14-15 (downlink then uplink leg, averaged),
solved in the inertial frame that coincides with the rotating frame at the reception time.
Filter: the instantaneous geometric range of Eq. 17. The difference (about -range_rate * tau, up to
~0.2 km for a lunar orbiter) is a genuine model error that the filter has to live with.
"""

from dataclasses import dataclass

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import SPEED_OF_LIGHT_LU_TU

STATE_SIZE = 6


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
    return (r_receiver - r_transponder) / rho


def _position_before(states, dt_back_tu, mu):
    """Rotating-frame positions dt_back earlier, by a 2nd-order Taylor step (tau < 1e-5 TU), then
    expressed in the inertial frame aligned with the rotating frame now. (m,6),(m,) -> (m,3)."""
    from liaison_cli.dynamics.crtbp import derivative

    acc = np.array([derivative(s, mu)[3:6] for s in states])
    r = states[:, 0:3] - states[:, 3:6] * dt_back_tu[:, None] + 0.5 * acc * dt_back_tu[:, None] ** 2
    angle = -dt_back_tu  # frame rotates at 1 rad/TU
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1], r[:, 2]], axis=1)


def two_way_light_time_range(receiver_states, transponder_states, mu, tol_tu=1e-16, max_iter=20):
    """Eq. 14-15: two-way range recorded by the receiver at the sample times. (m,6),(m,6) -> (m,) LU.

    Downlink: rho_d = |r_T(t - tau_d) - r_R(t)|; uplink: rho_u = |r_T(t - tau_d) - r_R(t - tau_d - tau_u)|;
    the measurement is (rho_d + rho_u) / 2.
    """
    c = SPEED_OF_LIGHT_LU_TU
    receiver_states = np.asarray(receiver_states, dtype=float)
    transponder_states = np.asarray(transponder_states, dtype=float)
    r_receiver_now = receiver_states[:, 0:3]
    tau_d = np.linalg.norm(transponder_states[:, 0:3] - r_receiver_now, axis=1) / c
    for _ in range(max_iter):
        r_t = _position_before(transponder_states, tau_d, mu)
        new = np.linalg.norm(r_t - r_receiver_now, axis=1) / c
        done = np.max(np.abs(new - tau_d)) < tol_tu
        tau_d = new
        if done:
            break
    r_transponder = _position_before(transponder_states, tau_d, mu)
    tau_u = tau_d.copy()
    for _ in range(max_iter):
        r_r = _position_before(receiver_states, tau_d + tau_u, mu)
        new = np.linalg.norm(r_transponder - r_r, axis=1) / c
        done = np.max(np.abs(new - tau_u)) < tol_tu
        tau_u = new
        if done:
            break
    return 0.5 * c * (tau_d + tau_u)


@dataclass(frozen=True)
class TwoWayRange:
    """Crosslink two-way range between spacecraft `receiver` (mothercraft) and `transponder`.

    Indices refer to rows of a (n_spacecraft, 6) state array. value/partials are the filter model
    (Eq. 17); simulate() produces noise-free truth with light time (Eq. 14-15).
    """

    receiver: int
    transponder: int

    def value(self, states):
        """(n_sc, 6) -> range in LU."""
        return geometric_range(states[self.receiver, 0:3], states[self.transponder, 0:3])

    def partials(self, states):
        """(n_sc, 6) -> H row (6 * n_sc,), Eq. 20."""
        h = np.zeros(states.shape[0] * STATE_SIZE)
        g = geometric_range_gradient(states[self.receiver, 0:3], states[self.transponder, 0:3])
        h[self.receiver * STATE_SIZE : self.receiver * STATE_SIZE + 3] = g
        h[self.transponder * STATE_SIZE : self.transponder * STATE_SIZE + 3] = -g
        return h

    def simulate(self, truth, mu, light_time=True):
        """Noise-free measurements from truth states (m, n_sc, 6) -> (m,) LU."""
        if light_time:
            return two_way_light_time_range(truth[:, self.receiver], truth[:, self.transponder], mu)
        return np.linalg.norm(truth[:, self.receiver, 0:3] - truth[:, self.transponder, 0:3], axis=1)
