"""A CRTBP orbit carried into the dated ephemeris model by multiple shooting (003: the EML1 halo).

Patch points: the CRTBP trajectory sampled every `node_spacing_s` from the epoch (CRTBP time scaled by the
nominal TU) and mapped to geocentric ICRF through the instantaneous Earth-Moon frame at each node's date.
Unknowns: every node's state; constraints: each segment's propagated end state equals the next node
(position and velocity). Newton with the minimum-norm update dX = -DF^+ F, DF = [Phi_i, -I] per segment,
until every defect is below 1e-6 km and 1e-9 km/s (003's continuity criterion), or, where no step lowers
the defects any more (the rounding floor), below 1e-4 km and 1e-7 km/s.

Globalised, so that the answer does not hang on the last bit of the linear algebra: Levenberg-Marquardt.
A step is taken only when it lowers the scaled defect norm; the Newton step (from a QR factorisation of the
scaled DF, not the normal equations DF DF^T, which square its condition number) is tried first, and damped
steps dX = -D^T (D D^T + lambda I)^-1 F, shorter and turned toward steepest descent, when it does not. A
CRTBP orbit mapped into the dated model starts thousands of km from continuity; full Newton steps from there
wandered (defects of 1e5 km) and landed, or not, by the rounding of the BLAS kernel; a line search along
the Newton direction stalled at 100 km; damped steps reach 1e-6 km in four to five Jacobians. Propagation: the fixed-step RK8 of the ephemeris
dynamics with its STM (`steps_per_node` per segment).

Long arcs in stages (`corrected_in_stages`): the dated orbit's phase drifts from the CRTBP orbit's (004's
EML1 halo over 60 d: by 1.5 d after 48 d, as the Earth-Moon distance and rate vary), so patch points taken
at the CRTBP's own phase are thousands of km from the dated orbit late in the arc; corrected in one piece,
such an arc stalled with 12-24 m/s velocity defects at every node spacing. So the arc is corrected
STAGE_DAYS at a time: each stage appends patch points from the CRTBP orbit re-phased at the corrected end
(the CRTBP state nearest it in the rotating frame) and the whole arc so far is corrected again.
"""

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular

from liaison_cli.dynamics.constants import MU, TU_S
from liaison_cli.dynamics.crtbp import rk4_states
from liaison_cli.dynamics.ephemeris import geocentric_state
from liaison_cli.dynamics.ephemeris_dynamics import rk8_ephemeris
from liaison_cli.dynamics.frames import crtbp_to_inertial, inertial_to_crtbp
from liaison_cli.dynamics.rk8 import RK8_A, RK8_B, RK8_C

POSITION_TOLERANCE_KM = 1e-6  # 003's continuity criterion: 1 mm
VELOCITY_TOLERANCE_KM_S = 1e-9  # and 1 um/s
# Over long unstable arcs (004's 60-day EML1 halos) the defects stop falling at a few 1e-7 km: the rounding of
# a 1.5-day RK8 segment, whose last bits differ by BLAS kernel. A correction whose damped steps can no longer
# lower the defects counts as converged when they are below these (10 cm, 0.1 mm/s): the truth starts from
# the first node, so the defects only say how closely the corrected orbit follows its reference.
FLOOR_POSITION_TOLERANCE_KM = 1e-4
FLOOR_VELOCITY_TOLERANCE_KM_S = 1e-7
# Velocity defects and steps count in km per VELOCITY_WEIGHT_S: a 1 mm/s defect weighs as a 1 m one.
VELOCITY_WEIGHT_S = 1e3
SUFFICIENT_DECREASE = 1e-4  # a step is taken when it lowers the merit by at least this share
DAMPING_FLOOR = 1e-9  # the smallest non-zero damping, relative to the mean diagonal of D D^T
MAX_DAMPING_TRIES = 16  # damping raised tenfold at most this many times per step
# Arc corrected at a time (corrected_in_stages): two EML1 halo periods, over which the dated orbit's phase
# drifts by a few hours from the CRTBP's. 12 to 24 d all converge on 004's 60-d EML1 halos.
STAGE_DAYS = 24.0
PHASE_SEARCH_STEP_S = 600.0  # sampling of the CRTBP orbit when re-phasing it on a corrected end


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
    return times_s, _mapped(state_lu, times_s, forces)


def _mapped(state_lu, times_s, forces: ForceModel) -> np.ndarray:
    """(len(times_s), 6) km, km/s: the CRTBP orbit from state_lu at times_s[0], mapped to ICRF at each time."""
    rotating = rk4_states(np.asarray(state_lu, dtype=float), (times_s - times_s[0]) / TU_S, 10.0 / TU_S, MU)
    return np.array([crtbp_to_inertial(rotating[k], forces.moon_state(t), MU) for k, t in enumerate(times_s)])


def corrected_in_stages(state_lu, epoch_s: float, span_s: float, node_spacing_s: float, forces: ForceModel,
                        steps_per_node: int = 200, max_iterations: int = 20) -> CorrectedOrbit:
    """The CRTBP orbit state_lu corrected over [epoch_s, epoch_s + span_s], STAGE_DAYS of arc at a time (module
    docstring); an arc no longer than one stage is plain multiple shooting from patch_points_from_crtbp. The
    result's defect histories run through every stage in turn (one entry per Jacobian, so the last is the
    final stage's last) and its iterations count them all. Stops at the first stage that does not converge
    (returned, converged False)."""
    times_s, seed = patch_points_from_crtbp(state_lu, epoch_s, span_s, node_spacing_s, forces)
    per_stage = max(1, int(round(STAGE_DAYS * 86400.0 / node_spacing_s)))
    end = min(per_stage, len(times_s) - 1)
    nodes, position_defects, velocity_defects = seed[: end + 1], (), ()
    while True:
        stage = multiple_shooting(times_s[: end + 1], nodes, forces, steps_per_node, max_iterations)
        position_defects += stage.position_defects_km
        velocity_defects += stage.velocity_defects_km_s
        if not stage.converged or end == len(times_s) - 1:
            return CorrectedOrbit(stage.node_times_s, stage.nodes, position_defects, velocity_defects,
                                  len(position_defects), stage.converged)
        following = min(end + per_stage, len(times_s) - 1)
        rephased = _rephased(state_lu, stage.nodes[-1], times_s[end], forces)
        nodes = np.vstack([stage.nodes, _mapped(rephased, times_s[end:following + 1], forces)[1:]])
        end = following


def _rephased(state_lu, node_km, t_s: float, forces: ForceModel) -> np.ndarray:
    """The state of the CRTBP orbit through state_lu nearest (position in LU, velocity in LU/TU) to node_km
    seen in the rotating frame of t_s: the nearest of PHASE_SEARCH_STEP_S samples over STAGE_DAYS (which covers
    a period of every orbit corrected in stages), refined between its neighbours by the parabola through the
    three squared distances, so the phase is a continuous function of the corrected end (picked from the
    samples alone, a last-bit change of the end could pick the next sample). It did not remove the spread of
    the 60-day EML1 halo between BLAS kernels (136-163 km: docs/reproducibility.md); that comes from the
    correction's own freedom."""
    target = inertial_to_crtbp(node_km, forces.moon_state(t_s), MU)
    step_tu = PHASE_SEARCH_STEP_S / TU_S
    samples_tu = np.arange(0.0, STAGE_DAYS * 86400.0, PHASE_SEARCH_STEP_S) / TU_S
    orbit = rk4_states(np.asarray(state_lu, dtype=float), samples_tu, 10.0 / TU_S, MU)
    squared = np.sum((orbit - target) ** 2, axis=1)
    k = int(np.argmin(squared))
    if not 0 < k < len(squared) - 1:
        return orbit[k]
    curvature = squared[k - 1] - 2.0 * squared[k] + squared[k + 1]
    offset = 0.5 * (squared[k - 1] - squared[k + 1]) / curvature if curvature > 0.0 else 0.0
    offset = min(max(offset, -1.0), 1.0)  # in samples, from sample k
    base = k - 1 if offset < 0.0 else k
    forward_tu = (k + offset - base) * step_tu
    return rk4_states(orbit[base], np.array([0.0, forward_tu]), 10.0 / TU_S, MU)[-1]


def segment_defects(node_times_s, nodes, forces: ForceModel, steps_per_node: int) -> np.ndarray:
    """(N, 6) km, km/s: each segment's propagated end state minus the next node."""
    ends = [forces.propagate(nodes[i], node_times_s[i], node_times_s[i + 1] - node_times_s[i], steps_per_node)
            for i in range(len(node_times_s) - 1)]
    return np.array(ends) - nodes[1:]


def defects_and_jacobian(node_times_s, nodes, forces: ForceModel, steps_per_node: int):
    """F (6N,) and DF (6N, 6N + 6): the defects and their partials [Phi_i, -I] in each segment's rows."""
    n_seg = len(node_times_s) - 1
    F = np.zeros(6 * n_seg)
    DF = np.zeros((6 * n_seg, 6 * (n_seg + 1)))
    for i in range(n_seg):
        end, phi = forces.propagate(nodes[i], node_times_s[i], node_times_s[i + 1] - node_times_s[i],
                                    steps_per_node, with_stm=True)
        F[6 * i : 6 * i + 6] = end - nodes[i + 1]
        DF[6 * i : 6 * i + 6, 6 * i : 6 * i + 6] = phi
        DF[6 * i : 6 * i + 6, 6 * i + 6 : 6 * i + 12] = -np.eye(6)
    return F, DF


def _scale(n_nodes: int) -> np.ndarray:
    """Per unknown: 1 for positions (km), VELOCITY_WEIGHT_S for velocities (km/s), so both halves weigh alike."""
    return np.tile([1.0, 1.0, 1.0, VELOCITY_WEIGHT_S, VELOCITY_WEIGHT_S, VELOCITY_WEIGHT_S], n_nodes)


def minimum_norm_step(F, DF, damping: float = 0.0) -> np.ndarray:
    """dX (6N + 6,) with the least scaled norm among the solutions of DF dX = -F (damping 0: Newton, from the
    QR factorisation of the scaled DF^T, DF^T = Q R, dX = -Q R^-T F), or Levenberg-Marquardt's damped step
    dX = -D^T (D D^T + damping I)^-1 F, D the scaled DF: shorter, and turned toward steepest descent."""
    scale = _scale(DF.shape[1] // 6)
    D = DF / scale
    if damping == 0.0:
        q, r = np.linalg.qr(D.T)
        return -(q @ solve_triangular(r, F, trans="T")) / scale
    normal = D @ D.T
    normal[np.diag_indices_from(normal)] += damping
    return -(D.T @ np.linalg.solve(normal, F)) / scale


def weighted_norm(defects) -> float:
    """The merit function: the 2-norm of the defects with velocities in km per VELOCITY_WEIGHT_S."""
    weighted = np.array(defects, dtype=float).reshape(-1, 6)
    weighted[:, 3:] *= VELOCITY_WEIGHT_S
    return float(np.linalg.norm(weighted))


def multiple_shooting(node_times_s, nodes, forces: ForceModel, steps_per_node: int = 200,
                      max_iterations: int = 40) -> CorrectedOrbit:
    """Levenberg-Marquardt on every node until each segment's defect is below the tolerances (or
    max_iterations Jacobians): a Newton step where it lowers the scaled defect norm, else damped steps."""
    node_times_s = np.asarray(node_times_s, dtype=float)
    nodes = np.array(nodes, dtype=float)
    pos_defects, vel_defects = [], []
    converged = False
    damping = 0.0
    for iteration in range(1, max_iterations + 1):
        F, DF = defects_and_jacobian(node_times_s, nodes, forces, steps_per_node)
        defects = F.reshape(-1, 6)
        pos_defects.append(float(np.max(np.linalg.norm(defects[:, :3], axis=1))))
        vel_defects.append(float(np.max(np.linalg.norm(defects[:, 3:], axis=1))))
        if pos_defects[-1] < POSITION_TOLERANCE_KM and vel_defects[-1] < VELOCITY_TOLERANCE_KM_S:
            converged = True
            break
        if not np.all(np.isfinite(F)):
            break
        nodes, damping, lowered = _damped_step(node_times_s, nodes, F, DF, damping, forces, steps_per_node)
        if not lowered:  # at the rounding floor, or stuck: no damping lowers the defects any more
            converged = pos_defects[-1] < FLOOR_POSITION_TOLERANCE_KM and vel_defects[-1] < FLOOR_VELOCITY_TOLERANCE_KM_S
            break
    return CorrectedOrbit(node_times_s, nodes, tuple(pos_defects), tuple(vel_defects), iteration, converged)


def _damped_step(node_times_s, nodes, F, DF, damping, forces: ForceModel, steps_per_node: int):
    """(new nodes, damping for the next step, lowered). Tries the step at the current damping; while it does
    not lower the merit by SUFFICIENT_DECREASE, raises the damping tenfold (from a floor of DAMPING_FLOOR of
    D D^T's mean diagonal) up to MAX_DAMPING_TRIES times; on success the next step starts with a tenth of it
    (0 below the floor). When no damping lowers the merit, the nodes are returned unchanged."""
    merit = weighted_norm(F)
    scaled = DF / _scale(DF.shape[1] // 6)
    floor = DAMPING_FLOOR * float(np.mean(np.sum(scaled * scaled, axis=1)))
    for _ in range(MAX_DAMPING_TRIES):
        step = minimum_norm_step(F, DF, damping).reshape(-1, 6)
        trial = nodes + step
        trial_merit = weighted_norm(segment_defects(node_times_s, trial, forces, steps_per_node))
        if trial_merit <= (1.0 - SUFFICIENT_DECREASE) * merit:
            lowered = damping / 10.0
            return trial, (0.0 if lowered < floor else lowered), True
        damping = max(10.0 * damping, floor)
    return nodes, damping, False
