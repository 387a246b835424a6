"""The dynamics interface: state + STM over an interval, given an epoch. Estimators see nothing else.

A model is a code and a parameter vector (plain data, so compiled estimators take it as arguments and
numba can cache them): `propagate_state_stm_into(model, params, state, t_tu, dt_tu, substeps, y, work)`,
with a parameter's column `propagate_parameter_into`, and the batch's RK8 `propagate_rk8_in_place`. The
CRTBP is code 0 (params = [mu]). A dated ephemeris model plugs in as a new code here and a new file beside
`crtbp.py`; the estimators do not change. The integrators themselves are in dynamics.integrators.
`DynamicsModel` is the Python side: truth propagation and the frame's trajectories.
"""

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from liaison_cli.compiled_calls import writable_c
from liaison_cli.dynamics.constants import M_PER_LU, TU_S
from liaison_cli.dynamics.ephemeris_dynamics import SENSITIVITY_SIZE, STM_SIZE
from liaison_cli.dynamics.ephemeris_model import ephemeris_state_stm_cr_scaled, ephemeris_state_stm_scaled
from liaison_cli.dynamics.crtbp_field import (added_terms_into, crtbp_params, field_accelerations, harmonics_term,
                                              has_added_terms, j2_term)
from liaison_cli.dynamics.integrators.rk4 import rk4_state_stm_into, rk4_states_forced
from liaison_cli.dynamics.integrators.rk8 import rk8_advance, rk8_states_forced, step_counts
from liaison_cli.dynamics.lunar_gravity import lunar_field, lunar_j2
from liaison_cli.dynamics.registry import CRTBP, DYNAMICS, MODEL_CRTBP, MODEL_EPHEMERIS
from liaison_cli.dynamics.trajectory import CrtbpTrajectory

M_S2_PER_LU_TU2 = M_PER_LU / TU_S**2  # acceleration units

# The propagation vector the filters' scratch holds: state (6), STM (36), and a dynamics parameter's column
# (6, propagate_parameter_into); the CRTBP's RK4 uses the first STM_SIZE entries.
PROPAGATION_SIZE = SENSITIVITY_SIZE

# Truth: compiled fixed-step RK4 of at most 10 s. Over 10 days it agrees with DOP853 at rtol 1e-13 to
# 2.0 mm for the 9,000 km lunar orbiter (DOP853 at the former rtol 1e-12 is itself 2 cm off); see
# tests/unit/dynamics/test_dynamics.py. A low orbit needs a shorter step (a 100 km lunar orbit at 10 s is
# 0.4 mm off per 600 s interval): the step is halved until the Richardson estimate of the truth's error grows
# by no more than TRUTH_TOLERANCE_M over any interval (DynamicsModel.truth_states), a tenth of the filter's
# default integration tolerance (dynamics.step_choice).
TRUTH_MAX_STEP_S = 10.0
TRUTH_MIN_STEP_S = 0.3125  # five halvings
TRUTH_TOLERANCE_M = 1e-5
# Halving stops, too, where two halvings in a row fail to shrink the estimate to this share of the smallest one
# so far (truncation error falls 16-fold per halving for RK4, 256-fold for RK8): the estimate is then the
# arithmetic's rounding, not the step's error, and the truth with the smallest estimate is kept. One miss alone
# can be a pre-asymptotic step (a 15 km perilune at 1800 s: 1.64e-4, 8.82e-5, then 1.57e-5 m). Against the
# smallest, not the one before: in the rounding the estimate wanders (1.8e-5, 3.5e-5, 1.5e-5, 2.7e-5 m), and a
# fall back from a high one is no sign of truncation. A 100 km orbit at 3600 s
# intervals (degree 30) was halved past the 0.3125 s floor to 0.23 s, 130 s of truth for 3 days, and 1.44 mm
# from DOP853 instead of 0.2 mm.
TRUTH_NOISE_FLOOR_RATIO = 0.5
TRUTH_NOISE_FLOOR_MISSES = 2
TRUTH_RK8_MAX_STEP_S = 60.0  # the first RK8 step of a truth with the lunar harmonics (halved as RK4's 10 s is)


@njit(cache=True)  # a call, not inlined: compiled and cached once, shared by every estimator and kind set
def _crtbp_state_stm_into(params, state, t_tu, dt_tu, substeps, y, work):
    rk4_state_stm_into(state, dt_tu, substeps, params, y, work)


@njit(cache=True)  # a call, not inlined (see _crtbp_state_stm_into)
def _ephemeris_state_stm_into(params, state, t_tu, dt_tu, substeps, y, work):
    xs, phi = ephemeris_state_stm_scaled(params, state, t_tu, dt_tu, substeps)
    for i in range(6):
        y[i] = xs[i]
        for j in range(6):
            y[6 + 6 * i + j] = phi[i, j]


@njit(cache=True)  # a call, not inlined (see _crtbp_state_stm_into)
def _ephemeris_parameter_into(params, parameter, state, t_tu, dt_tu, substeps, y):
    ephemeris_state_stm_cr_scaled(params, parameter, state, t_tu, dt_tu, substeps, y)


@njit(cache=True, inline="always")
def propagate_state_stm_into(model, params, state, t_tu, dt_tu, substeps, y, work):
    """(6,) state at t_tu -> y (42,) = [state (6), Phi(t_tu + dt_tu, t_tu) row-major (36)], with work (5, 42)
    the caller's scratch (no allocation per interval for the point-mass CRTBP; one for its added terms' scratch): the
    CRTBP by `substeps` fixed RK4 steps, the ephemeris model by `substeps` fixed RK8 steps.

    The model code is read at run time: each model's propagator is one compiled, cached function that every
    estimator calls, so an estimator is compiled once for every model (docs/performance.md, "Compile once").
    An unknown code raises (never a silent NaN)."""
    if model == MODEL_CRTBP:
        _crtbp_state_stm_into(params, state, t_tu, dt_tu, substeps, y, work)
    elif model == MODEL_EPHEMERIS:
        _ephemeris_state_stm_into(params, state, t_tu, dt_tu, substeps, y, work)
    else:
        raise ValueError("propagate_state_stm_into: unknown dynamics model code")


@njit(cache=True, inline="always")
def propagate_parameter_into(model, params, parameter, state, t_tu, dt_tu, substeps, y, work):
    """propagate_state_stm_into with the model's estimable parameter (registry: Dynamics.parameters) set to
    `parameter`, y (48,) = [state (6), Phi (36), gamma (6)] with gamma = d state / d parameter: the column of
    the transition that couples a parameter state to its spacecraft. The ephemeris model's parameter is C_R's
    relative correction (its C_R A/m times 1 + parameter); the CRTBP has none (the scenario refuses one)."""
    if model == MODEL_EPHEMERIS:
        _ephemeris_parameter_into(params, parameter, state, t_tu, dt_tu, substeps, y)
    else:
        raise ValueError("this dynamics model has no estimable parameter")


@njit(cache=True, inline="always")
def propagate_rk8_in_place(model, params, y, t_tu, dt_tu, n_steps, k, tmp):
    """In place: y (6,) state or (42,) [state, Phi(t, t0) row-major] from t_tu to t_tu + dt_tu, n_steps RK8
    steps; k (12, len(y)) and tmp (len(y),) are the caller's scratch (no allocation per interval)."""
    if model == MODEL_CRTBP:
        rk8_advance(y, dt_tu, n_steps, params, k, tmp)
    else:  # the batch runs with the CRTBP only (its Estimator descriptor); never a silent NaN
        raise ValueError("propagate_rk8_in_place: the batch's RK8 integrates the CRTBP only")


@dataclass(frozen=True, eq=False)
class DynamicsModel:
    name: str
    code: int
    params: np.ndarray
    # The truth's constant unmodelled acceleration on the rotating axes (LU/TU^2): model_error's; the filter
    # never sees it.
    truth_acceleration_lu_tu2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # The filter's own parameters where they differ from the truth's (a lunar field of a lower degree); None:
    # the truth's.
    filter_only_params: np.ndarray | None = None

    @property
    def descriptor(self):
        """What the model is and supports (dynamics.registry)."""
        return DYNAMICS[self.name]

    def truth_states(self, state0, times_tu, extra_acceleration_lu_tu2=None) -> np.ndarray:
        """High-accuracy truth (m, 6) at times_tu from state0 at times_tu[0]; the truth's constant unmodelled
        acceleration, plus extra_acceleration_lu_tu2 (m, 3) at the samples and linear between them (a
        Gauss-Markov force drawn per run; None: none), on the rotating axes."""
        times_tu = np.asarray(times_tu, dtype=float)
        forcing = np.broadcast_to(self.truth_acceleration_lu_tu2, (times_tu.shape[0], 3))
        if extra_acceleration_lu_tu2 is not None:
            forcing = forcing + extra_acceleration_lu_tu2
        state0, forcing = np.asarray(state0, dtype=float), np.ascontiguousarray(forcing, dtype=float)
        # A point-mass field keeps the recorded RK4; the lunar harmonics cost tens of point-mass evaluations each,
        # so a truth with added terms steps by RK8 (TRUTH_RK8_MAX_STEP_S), under the same tolerance.
        rk8 = has_added_terms(self.params)
        integrate, order = (rk8_states_forced, 8) if rk8 else (rk4_states_forced, 4)
        step_s = TRUTH_RK8_MAX_STEP_S if rk8 else TRUTH_MAX_STEP_S
        states = integrate(state0, times_tu, step_s / TU_S, self.params, forcing)
        best, best_growth, misses = states, np.inf, 0
        while step_s > TRUTH_MIN_STEP_S:  # the first step's result is kept wherever it meets the tolerance
            finer = integrate(state0, times_tu, 0.5 * step_s / TU_S, self.params, forcing)
            growth = truth_error_growth_m(states, finer, order)
            if growth <= TRUTH_TOLERANCE_M:
                return states
            misses = misses + 1 if growth > TRUTH_NOISE_FLOOR_RATIO * best_growth else 0
            if growth < best_growth:
                best, best_growth = states, growth
            if misses == TRUTH_NOISE_FLOOR_MISSES:  # rounding, not the step, sets the estimate: the best one seen
                return best
            states, step_s = finer, 0.5 * step_s
        return states

    def field_accelerations(self, params, states, times_tu) -> np.ndarray:
        """The model's field with parameters `params` at states (m, 6): accelerations (m, 3), LU/TU^2 (the CRTBP's
        rotating-frame terms included; the truth's unmodelled acceleration not)."""
        return field_accelerations(writable_c(states), np.asarray(params, dtype=float))

    def moon_relative_states(self, states, times_tu=None) -> np.ndarray:
        """(m, 6): the states (m, 6) about the Moon, which rests at (1 - mu, 0, 0) (rotating frame; times_tu is not
        needed)."""
        out = np.array(states, dtype=float)
        out[:, 0] -= 1.0 - float(self.params[0])
        return out

    def moon_field_difference(self, states, times_tu=None) -> np.ndarray:
        """(m, 3) LU/TU^2: the truth's added terms (crtbp_field: the lunar harmonics, or J2) minus the filter's at
        states (m, 6) (zero when they are the same field); the rotating frame's axes (times_tu is not needed)."""
        states = np.asarray(states, dtype=float)
        out = np.zeros((len(states), 3))
        acc, grad = np.empty(3), np.empty(6)
        for params, sign in ((self.params, 1.0), (self.filter_params, -1.0)):
            if not has_added_terms(params) or self.filter_only_params is None:
                continue
            for k, state in enumerate(states):
                added_terms_into(params, state[0], state[1], state[2], False, acc, grad)
                out[k] += sign * acc
        return out

    @property
    def unmodelled_acceleration_lu_tu2(self) -> np.ndarray:
        """The truth's constant acceleration the filter never models (3,), LU/TU^2."""
        return np.asarray(self.truth_acceleration_lu_tu2, dtype=float)

    def body_positions_lu(self, times_s) -> dict:
        """Occulting bodies' centres for measurements.visibility.not_occulted: the CRTBP's are fixed (its
        defaults)."""
        return {}

    @property
    def filter_params(self) -> np.ndarray:
        """The parameters of the filter's own model: the truth's, or a lunar field of its own degree."""
        return self.params if self.filter_only_params is None else self.filter_only_params

    def scaled_filter_params(self, cr_factor: float = 1.0, moon_gm_factor: float = 1.0) -> np.ndarray:
        """The filter's parameters with the Moon's GM times moon_gm_factor: mu (GM_moon / (GM_earth + GM_moon))
        becomes mu f / (1 + mu (f - 1)). The CRTBP has no C_R (cr_factor must be 1)."""
        if cr_factor != 1.0:
            raise ValueError("the CRTBP has no solar radiation pressure: no C_R to scale")
        params = self.filter_params
        mu = float(params[0])
        return np.array([mu * moon_gm_factor / (1.0 + mu * (moon_gm_factor - 1.0)), *params[1:]])

    @property
    def rotating_frame(self) -> bool:  # the states' frame turns at 1 rad/TU about z (measurements.tdoa)
        return self.descriptor.rotating_frame

    def trajectory(self, states, times_tu=None):
        """The sampled truth of one spacecraft (the CRTBP is autonomous: times_tu is not needed)."""
        return CrtbpTrajectory(states, self.params)

    def rk8_step_counts(self, positions_lu, dt_tu: float) -> np.ndarray:
        """Steps per interval (m - 1,) for the RK8 propagator along sampled positions (m, k, 3)."""
        return step_counts(positions_lu, dt_tu, self.params[0])


def truth_error_growth_m(coarse, fine, order: int = 4) -> float:
    """The largest change over one interval of the size of the Richardson estimate of the coarse truth's position
    error, |(coarse - fine) 2^p / (2^p - 1)| for an integrator of order p (RK4: 16 / 15), between two samplings
    (m, 6) of one trajectory at steps h and h / 2 (m). The size, not the error vector: an error that turns without growing is not counted (a vector difference
    would bound it from above; kept so, because the golden record and its kernel spreads were measured with it)."""
    error_m = np.linalg.norm(coarse[:, :3] - fine[:, :3], axis=1) * (2.0**order / (2.0**order - 1.0)) * M_PER_LU
    return float(np.max(np.abs(np.diff(error_m)))) if len(error_m) > 1 else 0.0


def crtbp_model(mu: float, truth_acceleration_m_s2=(0.0, 0.0, 0.0), moon_degree: int = 0,
                filter_moon_degree: int | None = None, filter_j2_only: bool = False) -> DynamicsModel:
    """The CRTBP of mass ratio mu; its truth also feels truth_acceleration_m_s2 (3,) on the rotating axes, and the
    Moon's field to moon_degree (0: a point mass), the filter's to filter_moon_degree (None: the truth's), or, with
    filter_j2_only, the Moon's J2 alone in closed form."""
    filter_moon_degree = moon_degree if filter_moon_degree is None else filter_moon_degree
    truth = crtbp_params(mu, harmonics_term(lunar_field(moon_degree)) if moon_degree else None)
    if filter_j2_only:
        own = crtbp_params(mu, j2_term(*lunar_j2()))
    elif filter_moon_degree == moon_degree:
        own = None
    else:
        own = crtbp_params(mu, harmonics_term(lunar_field(filter_moon_degree)) if filter_moon_degree else None)
    unmodelled = np.asarray(truth_acceleration_m_s2, dtype=float) / M_S2_PER_LU_TU2
    return DynamicsModel(CRTBP.name, CRTBP.code, truth, unmodelled, own)
