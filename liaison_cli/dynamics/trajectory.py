"""Sampled trajectories of participants, as the truth simulation of the measurements sees them.

A trajectory has `.states` (m, 6) in the rotating frame at the epochs, and
`.inertial_position_before(dt_back_tu)`: where the participant was dt_back earlier, expressed in the
inertial frame aligned with the rotating frame at each epoch (what light-time solutions need).
`.accelerations` (m, 3): d(velocity)/dt in the frame of `.states` (LU/TU^2), and `.rotating_frame`: that
frame turns at 1 rad/TU about z (the CRTBP frame) or is inertial (the dated scenarios' GCRF). The TDoA /
FDoA light-time model moves its ends to their emission and arrival times with them
(measurements.tdoa).
"""

from functools import cached_property

import numpy as np

from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.crtbp_field import field_accelerations


def states_with_accelerations(trajectory) -> np.ndarray:
    """(m, 9): the trajectory's states, then its accelerations (the layout of a known participant's row
    when a three-end light-time channel reads it: measurements.tdoa)."""
    return np.hstack([trajectory.states, trajectory.accelerations])


class CrtbpTrajectory:
    """A spacecraft moving in the CRTBP: positions dt_back earlier by a 2nd-order Taylor step
    (light times are below 1e-5 TU, so the third-order term is below a millimetre)."""

    rotating_frame = True

    def __init__(self, states, params):
        self.states = np.asarray(states, dtype=float)
        self.params = np.atleast_1d(np.asarray(params, dtype=float))  # the CRTBP's (dynamics.crtbp_field)

    @cached_property
    def accelerations(self) -> np.ndarray:
        """(m, 3) rotating-frame accelerations (Eq. 6-8, Coriolis and centrifugal terms included, and the lunar
        field when the parameters carry it)."""
        return field_accelerations(writable_c(self.states), self.params)  # writable: one signature

    def inertial_position_before(self, dt_back_tu):
        states, acc = self.states, self.accelerations  # computed once per trajectory: light-time iterations reuse it
        r = states[:, 0:3] - states[:, 3:6] * dt_back_tu[:, None] + 0.5 * acc * dt_back_tu[:, None] ** 2
        return rotate_to_inertial_now(r, dt_back_tu)


def rotate_to_inertial_now(r_then, dt_back_tu):
    """Rotating-frame positions at t - dt (m, 3) -> the inertial frame aligned with the rotating frame at t.
    The frame turns at 1 rad/TU, so the rotation angle is -dt."""
    angle = -dt_back_tu
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * r_then[:, 0] - s * r_then[:, 1], s * r_then[:, 0] + c * r_then[:, 1], r_then[:, 2]], axis=1)
