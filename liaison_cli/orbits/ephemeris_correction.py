"""A CRTBP orbit carried into the dated ephemeris model by multiple shooting (003: the EML1 halo).

Patch points: the CRTBP trajectory sampled every `node_spacing_s` from the epoch (CRTBP time scaled by the
nominal TU) and mapped to geocentric ICRF through the instantaneous Earth-Moon frame at each node's date.
Unknowns: every node's state; constraints: each segment's propagated end state equals the next node
(position and velocity). Newton with the minimum-norm update dX = -DF^T (DF DF^T)^-1 F, DF = [Phi_i, -I]
per segment, until every defect is below 1e-6 km and 1e-9 km/s (003's continuity criterion).
Propagation: the fixed-step RK8 of the ephemeris dynamics with its STM (`steps_per_node` per segment).
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import MU, TU_S
from liaison_cli.dynamics.crtbp import rk4_states
from liaison_cli.dynamics.ephemeris import geocentric_state
from liaison_cli.dynamics.ephemeris_dynamics import rk8_ephemeris
from liaison_cli.dynamics.frames import crtbp_to_inertial
from liaison_cli.dynamics.rk8 import RK8_A, RK8_B, RK8_C

POSITION_TOLERANCE_KM = 1e-6
VELOCITY_TOLERANCE_KM_S = 1e-9


@dataclass(frozen=True, eq=False)
class CorrectedOrbit:
    """node_times_s (N + 1,) TDB s; nodes (N + 1, 6) km, km/s; position / velocity defects per iteration (max
    over the patch points); iterations; converged."""

    node_times_s: np.ndarray
    nodes: np.ndarray
    position_defects_km: tuple
    velocity_defects_km_s: tuple
    iterations: int
    converged: bool


@dataclass(frozen=True, eq=False)
class ForceModel:
    """Everything the ephemeris propagator needs, bundled: the DE421 window, third bodies and GMs, the
    Earth's GM and C_R A/m (m^2/kg)."""

    window: object
    bodies: np.ndarray
    gms: np.ndarray
    gm_earth: float
    cr_am: float

    def propagate(self, x0, t_s, dt_s, n_steps, with_stm=False):
        y = np.zeros(42) if with_stm else np.array(x0, dtype=float)
        if with_stm:
            y[:6] = x0
            y[6::7] = 1.0
        w = self.window
        rk8_ephemeris(y, t_s, dt_s, n_steps, w.coeffs, w.start_s, w.interval_s, w.n_records, self.bodies, self.gms,
                      self.gm_earth, self.cr_am, RK8_A, RK8_B, RK8_C)
        return (y[:6].copy(), y[6:].reshape(6, 6).copy()) if with_stm else y

    def moon_state(self, t_s):
        w = self.window
        return geocentric_state(w.coeffs, w.start_s, w.interval_s, w.n_records, 301, t_s)


def patch_points_from_crtbp(state_lu, epoch_s: float, span_s: float, node_spacing_s: float, forces: ForceModel):
    """Node times (N + 1,) and the CRTBP orbit's states mapped to ICRF at them (N + 1, 6)."""
    n_nodes = int(round(span_s / node_spacing_s)) + 1
    times_s = epoch_s + np.arange(n_nodes) * node_spacing_s
    rotating = rk4_states(np.asarray(state_lu, dtype=float), (times_s - epoch_s) / TU_S, 10.0 / TU_S, MU)
    nodes = np.array([crtbp_to_inertial(rotating[k], forces.moon_state(t), MU) for k, t in enumerate(times_s)])
    return times_s, nodes


def multiple_shooting(node_times_s, nodes, forces: ForceModel, steps_per_node: int = 200,
                      max_iterations: int = 20) -> CorrectedOrbit:
    nodes = np.array(nodes, dtype=float)
    n_seg = len(node_times_s) - 1
    pos_defects, vel_defects = [], []
    converged = False
    for iteration in range(1, max_iterations + 1):
        F = np.zeros(6 * n_seg)
        DF = np.zeros((6 * n_seg, 6 * (n_seg + 1)))
        for i in range(n_seg):
            dt = node_times_s[i + 1] - node_times_s[i]
            end, phi = forces.propagate(nodes[i], node_times_s[i], dt, steps_per_node, with_stm=True)
            F[6 * i : 6 * i + 6] = end - nodes[i + 1]
            DF[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = phi
            DF[6 * i : 6 * i + 6, 6 * i + 6 : 6 * i + 12] = -np.eye(6)
        defects = F.reshape(n_seg, 6)
        pos_defects.append(float(np.max(np.linalg.norm(defects[:, :3], axis=1))))
        vel_defects.append(float(np.max(np.linalg.norm(defects[:, 3:], axis=1))))
        if pos_defects[-1] < POSITION_TOLERANCE_KM and vel_defects[-1] < VELOCITY_TOLERANCE_KM_S:
            converged = True
            break
        # Minimum-norm Newton step; scale velocities to km per (1000 s) so both halves weigh alike.
        scale = np.tile([1.0, 1.0, 1.0, 1e3, 1e3, 1e3], n_seg + 1)
        D = DF / scale
        dX = -(D.T @ np.linalg.solve(D @ D.T, F)) / scale
        nodes = nodes + dX.reshape(n_seg + 1, 6)
    return CorrectedOrbit(np.asarray(node_times_s), nodes, tuple(pos_defects), tuple(vel_defects), iteration, converged)
