"""The default process noise of a spacecraft that names none (issue 50 item 2): a PSD derived from what the
truth holds that the filter's model does not, plus a measured floor, instead of one constant for every scenario.

q (m^2/s^3, isotropic white acceleration; estimation.process_noise) is the sum of
- the floor, FLOOR_PSD_M2_S3: what a filter whose model is the truth's still needs, for its own linearisation
  and arithmetic. Measured on five formations nobody tuned, each at 60, 300 and 600 s with the step chosen by
  accuracy (`python -m benchmarks.untuned_formations --floors`, results/reference/untuned_floor_window.md): all
  15 cases are consistent at 3e-18 and at 1e-17; 14 at 1e-18 (the DRO + 100 km orbit at 60 s optimistic); 13 at
  1e-16 (the 200 km orbit at 60 and 300 s pessimistic); 10 at 1e-20, where the low orbits turn optimistic. The
  floor is the lower of the two values every case passes.
- a declared random truth force (model_error.truth_acceleration_sigma_m_s2, time constant tau) that the filter
  does not carry as empirical-acceleration states: its low-frequency density 2 sigma^2 tau (a first-order
  Gauss-Markov process's spectrum at zero frequency);
- every deterministic force the filter's model lacks or has wrong, evaluated along the spacecraft's nominal
  trajectory: the truth's constant unmodelled acceleration, the lunar GM's and C_R's errors (bias and drawn
  sigma together, sqrt(bias^2 + sigma^2); C_R's not when the filter estimates it) and, in the dated model, the bodies the filter leaves out. A slowly
  varying force has no white density of its own; it is taken as a Gauss-Markov process of that RMS and the
  settle time's correlation (the time after which the filter's consistency is judged): 2 a_rms^2 T_settle;
- the Moon's field beyond the filter's degree (moon_gravity.filter_degree below its degree): it varies along the
  orbit as fast as the field's features pass below it, so it is taken as a Gauss-Markov force of its RMS and its
  own correlation time, 2 a_rms^2 tau, tau the integral of its autocorrelation up to the first zero, in the
  spacecraft's radial / in-track / cross-track axes about the Moon (where a force the orbit carries along, as the
  degree-2 terms, stays correlated), sampled at the measurement epochs, at least one interval and at most T_settle
  (field_truncation_psd).
Each part is kept so the run can say where the default came from (default_noise_line).
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import M_S2_PER_AU, SECONDS_PER_DAY, TU_S
from liaison_cli.scenario.scenario_model import Scenario

FLOOR_PSD_M2_S3 = 3e-18
MAX_SAMPLES = 500  # trajectory samples for the unmodelled forces' RMS
MAX_FIELD_SAMPLES = 4000  # consecutive epochs for the field's autocorrelation (from t0)
NEGLIGIBLE_PSD_M2_S3 = 1e-6 * FLOOR_PSD_M2_S3  # a part below this is arithmetic residue, not printed


@dataclass(frozen=True)
class DefaultNoise:
    """A spacecraft's default PSD (m^2/s^3) and its parts {what: q}."""

    psd_m2_s3: float
    parts: dict


def _samples(m: int) -> np.ndarray:
    return np.unique(np.linspace(0, m - 1, min(m, MAX_SAMPLES)).astype(np.int64))


def _unmodelled_rms_m_s2(scenario: Scenario, model, states, times_s) -> float:
    """RMS over the sampled trajectory of |truth field - filter field + truth's unmodelled acceleration|, m/s^2."""
    error = scenario.model_error
    cr_factor = 1.0 + float(np.hypot(error.cr_bias, scenario.cr_error_sigma()))
    gm_factor = 1.0 + float(np.hypot(error.moon_gm_bias, error.moon_gm_sigma))
    estimated = scenario.filter.estimated_parameters or {}
    if model.descriptor.parameter("cr") is None or "cr" in estimated:  # none, or the filter estimates it
        cr_factor = 1.0
    filter_params = (model.scaled_filter_params(cr_factor, gm_factor) if (cr_factor, gm_factor) != (1.0, 1.0)
                     else model.filter_params)
    unmodelled = model.unmodelled_acceleration_lu_tu2
    if filter_params is model.params and not np.any(unmodelled):
        return 0.0
    k = _samples(len(times_s))
    times_tu = (np.asarray(times_s, dtype=float)[k] - float(times_s[0])) / TU_S
    difference = (model.field_accelerations(model.params, states[k], times_tu)
                  - model.field_accelerations(filter_params, states[k], times_tu) + unmodelled)
    if model.descriptor.lunar_field:  # the field's truncation has its own part (field_truncation_psd)
        difference -= model.moon_field_difference(states[k], times_tu)
    return float(np.sqrt(np.mean(np.sum(difference**2, axis=1)))) * M_S2_PER_AU


def _moon_ric(moon_relative) -> np.ndarray:
    """(m, 3, 3): each epoch's radial, in-track and cross-track unit vectors (rows) of states (m, 6) about the
    Moon (the model's moon_relative_states)."""
    r = moon_relative[:, 0:3]
    radial = r / np.linalg.norm(r, axis=1, keepdims=True)
    normal = np.cross(r, moon_relative[:, 3:6])
    cross = normal / np.linalg.norm(normal, axis=1, keepdims=True)
    return np.stack([radial, np.cross(cross, radial), cross], axis=1)


def correlation_time_s(signal, dt_s: float, longest_s: float) -> float:
    """The integral of a vector signal's (m, 3) normalised autocorrelation up to its first zero (trapezoid, lags of
    dt_s), within [dt_s, longest_s]."""
    total = float(np.sum(signal * signal))
    if total == 0.0:
        return dt_s
    m = len(signal)
    integral = 0.5
    for lag in range(1, min(m - 1, int(longest_s / dt_s)) + 1):
        rho = float(np.sum(signal[lag:] * signal[:-lag])) / (m - lag) / (total / m)
        if rho <= 0.0:
            break
        integral += rho
    return float(np.clip(integral * dt_s, dt_s, longest_s))


def field_truncation_psd(scenario: Scenario, model, states, times_s) -> float:
    """2 a_rms^2 tau of the Moon's field beyond the filter's degree along the spacecraft's orbit (module
    docstring), m^2/s^3; 0 where the filter's field is the truth's."""
    if not model.descriptor.lunar_field:
        return 0.0
    k = np.arange(min(len(times_s), MAX_FIELD_SAMPLES))
    times_tu = (np.asarray(times_s, dtype=float)[k] - float(times_s[0])) / TU_S
    difference = model.moon_field_difference(states[k], times_tu)
    if not np.any(difference):
        return 0.0
    ric = np.einsum("kij,kj->ki", _moon_ric(model.moon_relative_states(np.asarray(states, dtype=float)[k], times_tu)),
                    difference)
    dt_s = float(times_s[1] - times_s[0])
    tau_s = correlation_time_s(ric, dt_s, scenario.settle_days() * SECONDS_PER_DAY)
    rms = float(np.sqrt(np.mean(np.sum(difference**2, axis=1)))) * M_S2_PER_AU
    return 2.0 * rms**2 * tau_s


def default_psd(scenario: Scenario, model, states, times_s) -> DefaultNoise:
    """The default PSD of an estimated spacecraft flying states (m, 6) (filter units) at times_s (module
    docstring)."""
    parts = {"floor": FLOOR_PSD_M2_S3}
    error = scenario.model_error
    if error.truth_acceleration_sigma_m_s2 > 0.0 and scenario.filter.empirical_acceleration is None:
        parts["model_error random force"] = (2.0 * error.truth_acceleration_sigma_m_s2**2
                                             * error.truth_acceleration_time_constant_s)
    rms = _unmodelled_rms_m_s2(scenario, model, states, times_s)
    if 2.0 * rms**2 * scenario.settle_days() * SECONDS_PER_DAY > NEGLIGIBLE_PSD_M2_S3:
        parts["unmodelled forces"] = 2.0 * rms**2 * scenario.settle_days() * SECONDS_PER_DAY
    field = field_truncation_psd(scenario, model, states, times_s)
    if field > NEGLIGIBLE_PSD_M2_S3:
        parts[f"lunar field beyond {scenario.moon_gravity.filter_field_label}"] = field
    return DefaultNoise(float(sum(parts.values())), parts)


def default_noise_line(defaults: dict) -> str:
    """One line for the run text: the spacecraft that take the default and where it came from."""
    phrases = []
    for name, noise in defaults.items():
        parts = " + ".join(f"{what} {q:.2g}" for what, q in noise.parts.items())
        phrases.append(f"{name} {noise.psd_m2_s3:.2g}" + (f" ({parts})" if len(noise.parts) > 1 else ""))
    return (f"process noise: default PSD, m^2/s^3: {'; '.join(phrases)} (the floor for the filter's own "
            "linearisation, plus what the truth holds that the filter does not model; a process-noise key overrides)")
