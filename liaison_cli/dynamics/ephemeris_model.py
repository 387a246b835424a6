"""The dated ephemeris dynamics behind the dynamics interface (model code MODEL_EPHEMERIS).

The estimators see states in the same scaled units as for the CRTBP (positions in LU = 384,400 km,
velocities in LU/TU, time in TU since the scenario's epoch), here geocentric ICRF. Everything the compiled
propagator needs (the DE421 window, third bodies, GMs, C_R A/m, the epoch) is packed into the model's
parameter vector, so compiled estimators take it as a plain array.
"""

from functools import cached_property

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import AU_KM_S2, LU_KM, TU_S, VU_KM_S
from liaison_cli.dynamics.ephemeris import BODY_MOON
from liaison_cli.dynamics.ephemeris_dynamics import (NO_TERMS, SENSITIVITY_SIZE, STM_SIZE, TERM_MOON_HARMONICS,
                                                     add_terms_at_moon, ephemeris_derivative, term_of)
from liaison_cli.dynamics.integrators.rk8 import RK8_A, RK8_B, RK8_C, rk8_advance_ephemeris
from liaison_cli.dynamics.registry import DYNAMICS

SCALE = np.array([LU_KM, LU_KM, LU_KM, VU_KM_S, VU_KM_S, VU_KM_S])  # scaled units -> km, km/s
HEADER = 8  # S, R, N, B, gm_earth, cr_am, epoch_tdb_s, start of the terms table (0: none)
PARAM_CR_AM = 5
PARAM_TERMS_AT = 7


def with_cr_scaled(params: np.ndarray, factor: float) -> np.ndarray:
    """A copy of packed parameters whose C_R A/m is `factor` times the original (a mismodelled C_R)."""
    out = params.copy()
    out[PARAM_CR_AM] *= factor
    return out


def with_body_gm_scaled(params: np.ndarray, body: int, factor: float) -> np.ndarray:
    """A copy of packed parameters whose third body `body` (NAIF code) has `factor` times its GM (unchanged
    when the model does not carry that body)."""
    out = params.copy()
    n_segments, n_bodies = int(params[0]), int(params[3])
    bodies_at = HEADER + 3 * n_segments
    codes = params[bodies_at : bodies_at + n_bodies].astype(np.int64)
    for i in np.flatnonzero(codes == body):
        out[bodies_at + n_bodies + i] *= factor
    return out


def pack_params(window, bodies, gms, gm_earth: float, cr_am: float, epoch_tdb_s: float,
                terms=NO_TERMS) -> np.ndarray:
    """One flat float64 vector: the header, the window's record tables, the bodies, the coefficients, then the
    table of the forces beyond the point masses and SRP (ephemeris_dynamics.dated_terms; none: NO_TERMS)."""
    S, _, R, N = window.coeffs.shape
    header = np.array([S, R, N, len(bodies), gm_earth, cr_am, epoch_tdb_s, 0.0], dtype=float)
    out = np.concatenate([header, window.start_s, window.interval_s, window.n_records.astype(float),
                          np.asarray(bodies, dtype=float), np.asarray(gms, dtype=float), window.coeffs.ravel(),
                          np.asarray(terms, dtype=float)])
    if len(terms):
        out[PARAM_TERMS_AT] = len(out) - len(terms)
    return out


def terms_of(params) -> np.ndarray:
    """The terms table of packed parameters (NO_TERMS: none)."""
    at = int(params[PARAM_TERMS_AT])
    return params[at:] if at > 0 else NO_TERMS


def moon_field_of(params):
    """The Moon's harmonics' payload of packed parameters (None: a point-mass Moon)."""
    return term_of(terms_of(params), TERM_MOON_HARMONICS)


@njit(cache=True)
def _unpack(params):
    S, R, N, B = int(params[0]), int(params[1]), int(params[2]), int(params[3])
    off = HEADER
    start_s = params[off : off + S]
    off += S
    interval_s = params[off : off + S]
    off += S
    n_records = params[off : off + S].astype(np.int64)
    off += S
    bodies = params[off : off + B].astype(np.int64)
    off += B
    gms = params[off : off + B]
    off += B
    coeffs = np.ascontiguousarray(params[off : off + S * 3 * R * N]).reshape((S, 3, R, N))
    at = int(params[PARAM_TERMS_AT])
    terms = params[at:] if at > 0 else params[0:0]
    return coeffs, start_s, interval_s, n_records, bodies, gms, params[4], params[5], params[6], terms


@njit(cache=True)
def ephemeris_state_stm_scaled(params, state, t_tu, dt_tu, n_steps):
    """(6,) scaled state at t_tu (TU since the epoch) -> (state (6,), Phi (6, 6)) at t_tu + dt_tu, scaled
    units, by n_steps fixed RK8 steps of the DE421 + SRP field."""
    coeffs, start_s, interval_s, n_records, bodies, gms, gm_earth, cr_am, epoch, terms = _unpack(params)
    y = np.zeros(42)
    for i in range(6):
        y[i] = state[i] * SCALE[i]
        y[6 + 7 * i] = 1.0
    rk8_advance_ephemeris(y, epoch + t_tu * TU_S, dt_tu * TU_S, n_steps, coeffs, start_s, interval_s, n_records,
                          bodies, gms, gm_earth, cr_am, terms, RK8_A, RK8_B, RK8_C)
    out = np.empty(6)
    phi = np.empty((6, 6))
    for i in range(6):
        out[i] = y[i] / SCALE[i]
        for j in range(6):
            phi[i, j] = y[6 + 6 * i + j] * SCALE[j] / SCALE[i]
    return out, phi


@njit(cache=True)
def ephemeris_state_stm_cr_scaled(params, cr_scale, state, t_tu, dt_tu, n_steps, y):
    """ephemeris_state_stm_scaled with the filter's C_R A/m times (1 + cr_scale), written into y (48,) =
    [state (6), Phi row-major (36), gamma (6)], scaled units: gamma = d state / d cr_scale, the column of the
    transition that couples an estimated C_R state to the spacecraft (estimation.blocks)."""
    coeffs, start_s, interval_s, n_records, bodies, gms, gm_earth, cr_am, epoch, terms = _unpack(params)
    if not 1.0 + cr_scale > 0.0:  # a non-positive C_R: no physics to fly; NaN makes the run fail its health check
        for i in range(SENSITIVITY_SIZE):
            y[i] = np.nan
        return
    for i in range(SENSITIVITY_SIZE):
        y[i] = 0.0
    for i in range(6):
        y[i] = state[i] * SCALE[i]
        y[6 + 7 * i] = 1.0
    rk8_advance_ephemeris(y, epoch + t_tu * TU_S, dt_tu * TU_S, n_steps, coeffs, start_s, interval_s, n_records,
                          bodies, gms, gm_earth, cr_am * (1.0 + cr_scale), terms, RK8_A, RK8_B, RK8_C)
    # The integrated column is d/dlambda at C_R (1 + cr_scale) (1 + lambda): d/dcr_scale is it / (1 + cr_scale).
    for i in range(6):
        y[STM_SIZE + i] /= SCALE[i] * (1.0 + cr_scale)
        y[i] = y[i] / SCALE[i]
        for j in range(6):
            y[6 + 6 * i + j] = y[6 + 6 * i + j] * SCALE[j] / SCALE[i]  # ephemeris_state_stm_scaled's rounding


@njit(cache=True)
def ephemeris_accelerations_scaled(params, states, times_tu):
    """The field's accelerations (m, 3), LU/TU^2, at scaled states (m, 6) and times_tu (m,) past the epoch."""
    coeffs, start_s, interval_s, n_records, bodies, gms, gm_earth, cr_am, epoch, terms = _unpack(params)
    out = np.empty((states.shape[0], 3))
    y = np.empty(6)
    dy = np.empty(6)
    for k in range(states.shape[0]):
        for i in range(6):
            y[i] = states[k, i] * SCALE[i]
        ephemeris_derivative(epoch + times_tu[k] * TU_S, y, coeffs, start_s, interval_s, n_records, bodies, gms,
                             gm_earth, cr_am, terms, np.bool_(False), dy)  # no literal: one compile
        for i in range(3):
            out[k, i] = dy[3 + i] / AU_KM_S2
    return out


class SampledTrajectory:
    """Sampled states (m, 6) in the estimators' scaled units, geocentric ICRF (an inertial frame), at
    times_tu (m,) past the epoch of the packed parameters `params` (the truth's field)."""

    rotating_frame = False

    def __init__(self, states, params=None, times_tu=None):
        self.states = np.asarray(states, dtype=float)
        self.params, self.times_tu = params, times_tu

    @cached_property
    def accelerations(self) -> np.ndarray:
        """(m, 3) the truth field's accelerations at the samples (what moves a TDoA end over its light time)."""
        if self.params is None:
            raise ValueError("SampledTrajectory: accelerations need the model's parameters and the sample times")
        return ephemeris_accelerations_scaled(self.params, self.states, np.asarray(self.times_tu, dtype=float))


class EphemerisDynamicsModel:
    """The DynamicsModel of a dated scenario: code, packed parameters, and the adaptive truth."""

    name = "ephemeris"

    @property
    def descriptor(self):
        """What the model is and supports (dynamics.registry)."""
        return DYNAMICS[self.name]

    @property
    def rotating_frame(self) -> bool:  # geocentric ICRF (measurements.tdoa)
        return self.descriptor.rotating_frame

    def __init__(self, window, bodies, gms, gm_earth, cr_am, epoch_tdb_s, filter_bodies=None,
                 truth_acceleration_km_s2=(0.0, 0.0, 0.0), terms=NO_TERMS, filter_terms=None):
        """bodies / gms: the truth's third bodies; filter_bodies: the subset the filter models (default all);
        truth_acceleration_km_s2 (3,): the truth's unmodelled constant force on the ICRF axes; terms: the truth's
        forces beyond the point masses and SRP (ephemeris_dynamics.dated_terms: the lunar harmonics; NO_TERMS:
        none), filter_terms: the filter's (None: the truth's)."""
        self.code = self.descriptor.code
        self.window, self.bodies, self.gms = window, np.asarray(bodies), np.asarray(gms, dtype=float)
        self.gm_earth, self.cr_am, self.epoch_tdb_s = gm_earth, cr_am, epoch_tdb_s
        self.terms = np.asarray(terms, dtype=float)
        self.filter_terms = self.terms if filter_terms is None else np.asarray(filter_terms, dtype=float)
        self.params = pack_params(window, self.bodies, self.gms, gm_earth, cr_am, epoch_tdb_s, self.terms)
        self.truth_acceleration_km_s2 = np.asarray(truth_acceleration_km_s2, dtype=float)
        keep = np.isin(self.bodies, self.bodies if filter_bodies is None else filter_bodies)
        if BODY_MOON not in self.bodies[keep]:  # a filter without the Moon has no lunar field either
            self.filter_terms = NO_TERMS
        self.filter_params = pack_params(window, self.bodies[keep], self.gms[keep], gm_earth, cr_am, epoch_tdb_s,
                                         self.filter_terms)

    def scaled_filter_params(self, cr_factor: float = 1.0, moon_gm_factor: float = 1.0) -> np.ndarray:
        """The filter's parameters with its C_R A/m times cr_factor and the Moon's GM times moon_gm_factor."""
        return with_body_gm_scaled(with_cr_scaled(self.filter_params, cr_factor), BODY_MOON, moon_gm_factor)

    def field_accelerations(self, params, states, times_tu) -> np.ndarray:
        """The field with packed parameters `params` at scaled states (m, 6), times_tu past the epoch: (m, 3),
        LU/TU^2 (the truth's unmodelled acceleration not included)."""
        return ephemeris_accelerations_scaled(np.ascontiguousarray(params, dtype=float),
                                              np.ascontiguousarray(states, dtype=float),
                                              np.ascontiguousarray(times_tu, dtype=float))

    @property
    def unmodelled_acceleration_lu_tu2(self) -> np.ndarray:
        """The truth's constant acceleration the filter never models (3,), LU/TU^2."""
        return self.truth_acceleration_km_s2 / AU_KM_S2

    @property
    def moon_gm_km3_s2(self) -> float | None:
        """The Moon's GM in the truth's bodies (None when they leave the Moon out)."""
        return float(self.gms[list(self.bodies).index(BODY_MOON)]) if BODY_MOON in self.bodies else None

    def moon_states_km(self, times_tu) -> np.ndarray:
        """(m, 6) the Moon's geocentric ICRF states (DE421), km, km/s, at times_tu past the epoch."""
        return self._moon_states_km_at(np.asarray(times_tu, dtype=float) * TU_S)

    def _moon_states_km_at(self, times_s) -> np.ndarray:
        from liaison_cli.dynamics.ephemeris import geocentric_state

        w = self.window
        return np.array([geocentric_state(w.coeffs, w.start_s, w.interval_s, w.n_records, BODY_MOON,
                                          self.epoch_tdb_s + float(t)) for t in np.asarray(times_s, dtype=float)])

    def moon_relative_states(self, states, times_tu) -> np.ndarray:
        """(m, 6) scaled: the states (m, 6) about the Moon (its DE421 state at times_tu subtracted), ICRF axes."""
        return np.asarray(states, dtype=float) - self.moon_states_km(times_tu) / SCALE

    def moon_field_difference(self, states, times_tu) -> np.ndarray:
        """(m, 3) LU/TU^2: the truth's terms acting from the Moon (the lunar harmonics, or J2) minus the filter's at
        states (m, 6) and times_tu (zero when they are the same); ICRF axes."""
        states = np.asarray(states, dtype=float)
        out = np.zeros((len(states), 3))
        gm_moon = self.moon_gm_km3_s2
        if self.filter_terms is self.terms or gm_moon is None:
            return out
        moon_km = self.moon_states_km(times_tu)
        grad = np.zeros((3, 3))
        for terms, sign in ((self.terms, 1.0), (self.filter_terms, -1.0)):
            for k, t in enumerate(np.asarray(times_tu, dtype=float)):
                acc = np.zeros(3)
                add_terms_at_moon(terms, self.epoch_tdb_s + t * TU_S, states[k, :3] * SCALE[:3], moon_km[k, :3],
                                  gm_moon, False, acc, grad)
                out[k] += sign * acc / AU_KM_S2
        return out

    def body_positions_lu(self, times_s) -> dict:
        """The Earth (origin) and the Moon's geocentric positions (m, 3) at times_s past the epoch, scaled."""
        moon_km = self._moon_states_km_at(times_s)[:, :3]
        return {"earth_lu": np.zeros(3), "moon_lu": moon_km / LU_KM}

    def truth_states(self, state0, times_tu, extra_acceleration_lu_tu2=None) -> np.ndarray:
        """Truth (m, 6), scaled units, from state0 (scaled) at times_tu[0] (TU since the epoch); with
        extra_acceleration_lu_tu2 (m, 3) an unmodelled force at the samples and linear between them (ICRF). A
        low or elliptical lunar orbit (ephemeris_dynamics.bound_to_moon) is integrated about the Moon."""
        from liaison_cli.dynamics.ephemeris_dynamics import bound_to_moon, dop853_ephemeris_states

        times_s = self.epoch_tdb_s + np.asarray(times_tu, dtype=float) * TU_S
        table = None if extra_acceleration_lu_tu2 is None else np.asarray(extra_acceleration_lu_tu2) * AU_KM_S2
        moon = self.moon_states_km(np.asarray(times_tu[:1], dtype=float))[0]
        centred = self.moon_gm_km3_s2 is not None and bound_to_moon(np.asarray(state0) * SCALE, moon,
                                                                    self.moon_gm_km3_s2)
        km = dop853_ephemeris_states(np.asarray(state0) * SCALE, times_s[0], times_s, self.window, self.bodies,
                                     self.gms, self.gm_earth, self.cr_am,
                                     acceleration_km_s2=self.truth_acceleration_km_s2, acceleration_table_km_s2=table,
                                     terms=self.terms, moon_centred=centred)
        return km / SCALE

    def trajectory(self, states, times_tu):
        return SampledTrajectory(states, self.params, times_tu)
