"""A CRTBP orbit carried into the dated ephemeris model by multiple shooting (003: the EML1 halo).

Patch points: the CRTBP trajectory sampled every `node_spacing_s` from the epoch (CRTBP time scaled by the
nominal TU) and mapped to geocentric ICRF through the instantaneous Earth-Moon frame at each node's date.
Unknowns: every node's state; constraints: each segment's propagated end state equals the next node
(position and velocity), DF = [Phi_i, -I] per segment; until every defect is below 1e-6 km and 1e-9 km/s
(003's continuity criterion), or, where no step lowers the defects any more (the rounding floor), below
1e-4 km and 1e-7 km/s.

One solution, whatever the rounding. Two things let the last bits of the BLAS kernel choose the orbit (004's
60-day EML1 halo: nodes 29-299 km apart between the four kernels of docs/reproducibility.md):
- The patch points. A periodic orbit's are taken within its first period (along_orbit). Propagated on
  through five unstable revolutions, the last-bit differences of the family member's state grew (x1.4e5
  over the first stage's two, 8e-10 to 1.1e-4 km): the second and third stages' patch points differed by
  340-380 km between the host's kernel and Sandybridge, and the corrected orbit follows its patch points.
  Taken within a period, they differ by at most 2.2e-7 km.
- The freedom left: 6N defects in 6N + 6 unknowns leave six degrees of freedom (any dated trajectory near the
  patch points is continuous). With the minimum-norm Newton update dX = -DF^+ F at every iterate, the answer
  was the member of that family the Levenberg-Marquardt path happened to reach (halving three steps of the
  9-day EML1 halo's path moved it by 8.9 km). So every correction is taken in one fixed subspace: the row
  space of the patch points' own (scaled) Jacobian D_0, X - X_0 = Q w / scale with D_0^T = Q R, the
  orthogonal complement of the family's tangent there. The system in w is square (6N by 6N; at the patch
  points its Jacobian D_0 Q = R^T is as well conditioned as D_0) and its root isolated, the same whatever
  the path; the first Newton step is the minimum-norm one, as before, and the root is, to first order, the
  continuous orbit nearest the patch points. Pinning six unknowns instead (the first and last nodes'
  positions) made the system singular for orbits flown over whole periods (004's DRO over two: velocity
  defects of 0.5-1.1 m/s that no step removed, at every node spacing).

Globalised, so that convergence does not hang on the last bit of the linear algebra: Levenberg-Marquardt.
A step is taken only when it lowers the scaled defect norm; the Newton step dw = -J^-1 F, J = D Q, is tried
first, and damped steps dw = -J^T (J J^T + lambda I)^-1 F, shorter and turned toward steepest descent, when
it does not. A CRTBP orbit mapped into the dated model starts thousands of km from continuity; full Newton
steps from there wandered (defects of 1e5 km) and landed, or not, by the rounding of the BLAS kernel; a line
search along the Newton direction stalled at 100 km; damped steps reach 1e-6 km in four to five Jacobians.
Propagation: the fixed-step RK8 of the ephemeris dynamics with its STM (`steps_per_node` per segment).

Long arcs in stages (`corrected_in_stages`): the dated orbit's phase drifts from the CRTBP orbit's (004's
EML1 halo over 60 d: by 1.5 d after 48 d, as the Earth-Moon distance and rate vary), so patch points taken
at the CRTBP's own phase are thousands of km from the dated orbit late in the arc; corrected in one piece,
such an arc stalled with 12-24 m/s velocity defects at every node spacing. So the arc is corrected
STAGE_DAYS at a time: each stage appends patch points from the CRTBP orbit re-phased at the corrected end
(the CRTBP state nearest it in the rotating frame) and the whole arc so far is corrected again.
"""

from dataclasses import dataclass, field

import numpy as np

from liaison_cli.dynamics.constants import MU, TU_S
from liaison_cli.dynamics.ephemeris import geocentric_state
from liaison_cli.dynamics.ephemeris_dynamics import NO_TERMS
from liaison_cli.dynamics.frames import crtbp_to_inertial, inertial_to_crtbp
from liaison_cli.dynamics.integrators.rk4 import rk4_states
from liaison_cli.dynamics.integrators.rk8 import RK8_A, RK8_B, RK8_C, rk8_advance_ephemeris

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
    Earth's GM, C_R A/m (m^2/kg) and the forces beyond those (ephemeris_dynamics.dated_terms: the lunar harmonics;
    NO_TERMS: none)."""

    window: object
    bodies: np.ndarray
    gms: np.ndarray
    gm_earth: float
    cr_am: float
    terms: np.ndarray = field(default_factory=lambda: NO_TERMS)

    def propagate(self, x0, t_s, dt_s, n_steps, with_stm=False):
        y = np.zeros(42) if with_stm else np.array(x0, dtype=float)
        if with_stm:
            y[:6] = x0
            y[6::7] = 1.0
        w = self.window
        rk8_advance_ephemeris(y, t_s, dt_s, n_steps, w.coeffs, w.start_s, w.interval_s, w.n_records, self.bodies,
                              self.gms, self.gm_earth, self.cr_am, self.terms, RK8_A, RK8_B, RK8_C)
        return (y[:6].copy(), y[6:].reshape(6, 6).copy()) if with_stm else y

    def moon_state(self, t_s):
        w = self.window
        return geocentric_state(w.coeffs, w.start_s, w.interval_s, w.n_records, 301, t_s)


def patch_points_from_crtbp(state_lu, epoch_s: float, span_s: float, node_spacing_s: float, forces: ForceModel,
                            period_tu: float | None = None):
    """Node times (N + 1,) and the CRTBP orbit's states mapped to ICRF at them (N + 1, 6); period_tu: the
    orbit's period, when it is periodic (see along_orbit)."""
    n_nodes = int(round(span_s / node_spacing_s)) + 1
    times_s = epoch_s + np.arange(n_nodes) * node_spacing_s
    return times_s, _mapped(state_lu, times_s, forces, period_tu)


def along_orbit(state_lu, elapsed_tu, period_tu: float | None = None) -> np.ndarray:
    """(m, 6) LU, LU/TU: the CRTBP orbit through state_lu at the times elapsed_tu (>= 0) after it. A periodic
    orbit's states are taken within its first period (elapsed_tu modulo period_tu): propagated along an
    unstable orbit for longer, the last bits of state_lu, which differ between BLAS kernels (the family member
    is computed: 004's 11.94-d EML1 halo's z differs by ~300 ulp between the host's kernel and Sandybridge),
    grew without bound, so 60-day patch points, and the orbit corrected from them, followed the kernel
    (docs/reproducibility.md)."""
    elapsed_tu = np.asarray(elapsed_tu, dtype=float)
    phases = elapsed_tu if period_tu is None else np.mod(elapsed_tu, period_tu)
    order = np.argsort(phases, kind="stable")
    grid = np.concatenate([[0.0], phases[order]])  # rk4_states starts at its first time
    states = np.empty((len(phases), 6))
    states[order] = rk4_states(np.asarray(state_lu, dtype=float), grid, 10.0 / TU_S, np.array([MU]))[1:]
    return states


def _mapped(state_lu, times_s, forces: ForceModel, period_tu: float | None = None, phase_tu: float = 0.0):
    """(len(times_s), 6) km, km/s: the CRTBP orbit through state_lu, phase_tu after it at times_s[0], mapped to
    ICRF at each time."""
    rotating = along_orbit(state_lu, phase_tu + (times_s - times_s[0]) / TU_S, period_tu)
    return np.array([crtbp_to_inertial(rotating[k], forces.moon_state(t), MU) for k, t in enumerate(times_s)])


def corrected_in_stages(state_lu, epoch_s: float, span_s: float, node_spacing_s: float, forces: ForceModel,
                        steps_per_node: int = 200, max_iterations: int = 20,
                        period_tu: float | None = None) -> CorrectedOrbit:
    """The CRTBP orbit state_lu (of period period_tu, if periodic) corrected over [epoch_s, epoch_s + span_s],
    STAGE_DAYS of arc at a time (module docstring); an arc no longer than one stage is plain multiple shooting
    from patch_points_from_crtbp. The result's defect histories run through every stage in turn (one entry per
    Jacobian, so the last is the final stage's last) and its iterations count them all. Stops at the first
    stage that does not converge (returned, converged False)."""
    times_s, seed = patch_points_from_crtbp(state_lu, epoch_s, span_s, node_spacing_s, forces, period_tu)
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
        phase_tu = _rephased(state_lu, stage.nodes[-1], times_s[end], forces, period_tu)
        nodes = np.vstack([stage.nodes, _mapped(state_lu, times_s[end:following + 1], forces, period_tu,
                                                phase_tu)[1:]])
        end = following


def _rephased(state_lu, node_km, t_s: float, forces: ForceModel, period_tu: float | None = None) -> float:
    """The phase (TU after state_lu) of the CRTBP orbit's state nearest (position in LU, velocity in LU/TU) to
    node_km seen in the rotating frame of t_s: the nearest of samples about PHASE_SEARCH_STEP_S apart over a
    period (without one: over STAGE_DAYS, which covers a period of every orbit corrected in stages), refined
    between its neighbours by the parabola through the three squared distances, so the phase is a continuous
    function of the corrected end (picked from the samples alone, a last-bit change of the end could pick the
    next sample)."""
    target = inertial_to_crtbp(node_km, forces.moon_state(t_s), MU)
    span_tu = period_tu if period_tu is not None else STAGE_DAYS * 86400.0 / TU_S
    n_samples = int(np.ceil(span_tu * TU_S / PHASE_SEARCH_STEP_S))
    step_tu = span_tu / n_samples
    squared = np.sum((along_orbit(state_lu, np.arange(n_samples) * step_tu, period_tu) - target) ** 2, axis=1)
    k = int(np.argmin(squared))
    if period_tu is None and not 0 < k < n_samples - 1:
        return k * step_tu
    before, after = squared[k - 1], squared[(k + 1) % n_samples]  # a period's samples wrap around
    curvature = before - 2.0 * squared[k] + after
    offset = 0.5 * (before - after) / curvature if curvature > 0.0 else 0.0
    return (k + min(max(offset, -1.0), 1.0)) * step_tu  # offset in samples, from sample k


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


def seed_row_space(DF) -> np.ndarray:
    """(6N + 6, 6N): an orthonormal basis Q (in scaled unknowns) of the row space of the seed's scaled Jacobian
    D, from its QR factorisation D^T = Q R. Every correction is X - X_seed = Q w / scale (module docstring)."""
    q, _ = np.linalg.qr((DF / _scale(DF.shape[1] // 6)).T)
    return q


def shooting_step(F, J, damping: float = 0.0) -> np.ndarray:
    """dw (6N,) for the square Jacobian J = D Q of the defects in the coordinates w: Newton's dw = -J^-1 F
    (damping 0), or Levenberg-Marquardt's damped step dw = -J^T (J J^T + damping I)^-1 F: shorter, and turned
    toward steepest descent."""
    if damping == 0.0:
        return -np.linalg.solve(J, F)
    normal = J @ J.T
    normal[np.diag_indices_from(normal)] += damping
    return -(J.T @ np.linalg.solve(normal, F))


def weighted_norm(defects) -> float:
    """The merit function: the 2-norm of the defects with velocities in km per VELOCITY_WEIGHT_S."""
    weighted = np.array(defects, dtype=float).reshape(-1, 6)
    weighted[:, 3:] *= VELOCITY_WEIGHT_S
    return float(np.linalg.norm(weighted))


def multiple_shooting(node_times_s, nodes, forces: ForceModel, steps_per_node: int = 200,
                      max_iterations: int = 40) -> CorrectedOrbit:
    """Levenberg-Marquardt from the patch points `nodes` until each segment's defect is below the tolerances
    (or max_iterations Jacobians): a Newton step where it lowers the scaled defect norm, else damped steps;
    every correction in the row space of the patch points' Jacobian (seed_row_space), so the system is square
    and its root the same whatever the path to it."""
    node_times_s = np.asarray(node_times_s, dtype=float)
    nodes = np.array(nodes, dtype=float)
    pos_defects, vel_defects = [], []
    converged = False
    damping = 0.0
    to_nodes = None  # (6N + 6, 6N): a change of the coordinates w to the change of the nodes' states
    for iteration in range(1, max_iterations + 1):
        F, DF = defects_and_jacobian(node_times_s, nodes, forces, steps_per_node)
        if to_nodes is None:
            scale = _scale(len(nodes))
            to_nodes = seed_row_space(DF) / scale[:, None]
        defects = F.reshape(-1, 6)
        pos_defects.append(float(np.max(np.linalg.norm(defects[:, :3], axis=1))))
        vel_defects.append(float(np.max(np.linalg.norm(defects[:, 3:], axis=1))))
        if pos_defects[-1] < POSITION_TOLERANCE_KM and vel_defects[-1] < VELOCITY_TOLERANCE_KM_S:
            converged = True
            break
        if not np.all(np.isfinite(F)):
            break
        nodes, damping, lowered = _damped_step(node_times_s, nodes, F, DF @ to_nodes, to_nodes, damping, forces,
                                               steps_per_node)
        if not lowered:  # at the rounding floor, or stuck: no damping lowers the defects any more
            converged = pos_defects[-1] < FLOOR_POSITION_TOLERANCE_KM and vel_defects[-1] < FLOOR_VELOCITY_TOLERANCE_KM_S
            break
    return CorrectedOrbit(node_times_s, nodes, tuple(pos_defects), tuple(vel_defects), iteration, converged)


def _damped_step(node_times_s, nodes, F, J, to_nodes, damping, forces: ForceModel, steps_per_node: int):
    """(new nodes, damping for the next step, lowered). Tries the step at the current damping; while it does
    not lower the merit by SUFFICIENT_DECREASE, raises the damping tenfold (from a floor of DAMPING_FLOOR of
    J J^T's mean diagonal) up to MAX_DAMPING_TRIES times; on success the next step starts with a tenth of it
    (0 below the floor). When no damping lowers the merit, the nodes are returned unchanged."""
    merit = weighted_norm(F)
    floor = DAMPING_FLOOR * float(np.mean(np.sum(J * J, axis=1)))
    for _ in range(MAX_DAMPING_TRIES):
        trial = nodes + (to_nodes @ shooting_step(F, J, damping)).reshape(-1, 6)
        trial_merit = weighted_norm(segment_defects(node_times_s, trial, forces, steps_per_node))
        if trial_merit <= (1.0 - SUFFICIENT_DECREASE) * merit:
            lowered = damping / 10.0
            return trial, (0.0 if lowered < floor else lowered), True
        damping = max(10.0 * damping, floor)
    return nodes, damping, False
