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
  orbit as fast as the field's features pass below it, so it is measured as a Gauss-Markov force of its RMS and its
  own correlation time, 2 a_rms^2 tau, tau the integral of its autocorrelation up to the first zero, in the
  spacecraft's radial / in-track / cross-track axes about the Moon (where a force the orbit carries along, as the
  degree-2 terms, stays correlated), sampled at the measurement epochs, or on a finer grid when they cannot resolve
  it, and at most T_settle (field_truncation_psd); the part is FIELD_PART_FACTOR (0.3) of that: the field's error
  is oscillatory, and flown apart the truth's field and the filter's open what 0.07-0.6 of 2 a_rms^2 tau would
  (benchmarks.lunar_noise_coupling);
- that field's error reaching a spacecraft through its links: COUPLING_SHARE (1e-4) of each linked spacecraft's
  2 a_rms^2 tau (with_field_coupling). The linked one's coloured error leaks through the crosslink into a relay
  that has no field error of its own; with the user's part lowered and the relay at the floor, the relay's NEES
  left its band entirely (benchmarks.lunar_noise_coupling).
The factor and the share were picked on benchmarks.lunar_noise_coupling's relay formation and checked on twelve
formations, eight of them out of sample, with two campaign seeds (benchmarks.lunar_default_rule,
results/reference/lunar_default_rule.md): 24 of 48 spacecraft consistent, against 11 with the part at 2 a_rms^2 tau
and no share; 4 optimistic, the EML2 halo + 80 km orbiter at node 90 deg.
Not a bound by itself: that formation's orbiter (truth degree 60, filter 15) runs at err/sigma 0.71-0.75 at node 0
deg and 2.20-2.23 at node 90 deg under the rule (the table). So every command that flies a filter on a
scenario has LinCov check these defaults first, where LinCov has a budget for the scenario, and raise a field part
it finds optimistic (campaign.engine.noise_check); what is here is the rule before that check.
Each part is kept so the run can say where the default came from (default_noise_line).
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import M_S2_PER_AU, SECONDS_PER_DAY, TU_S
from liaison_cli.scenario.scenario_model import Scenario

FLOOR_PSD_M2_S3 = 3e-18
MAX_SAMPLES = 500  # samples for an RMS: the unmodelled forces' (and the field's, from fewer epochs than this)
MAX_FIELD_SAMPLES = 4000  # consecutive epochs for the field's autocorrelation (from t0)
NEGLIGIBLE_PSD_M2_S3 = 1e-6 * FLOOR_PSD_M2_S3  # a part below this is arithmetic residue, not printed
# The omitted field's correlation time where the measurement epochs resolve it poorly (within 5 intervals;
# field_truncation_psd): measured again on the orbit's first day interpolated every 10 s or less, or flown again
# over three revolutions where the epochs are too far apart to interpolate.
RESOLVED_SAMPLES = 5
MAX_INTERPOLATED_ANGLE_RAD = 0.6  # the cubic's error r theta^4 / 384: 0.6 km on a 100 km orbit
FLOWN_REVOLUTIONS = 3.0
# The rule for a truncated field (module docstring), checked by benchmarks.lunar_default_rule.
FIELD_PART_FACTOR = 0.3
COUPLING_SHARE = 1e-4
FIELD_PART_PREFIX = "lunar field"  # the parts' labels that come from the field (campaign.engine.noise_check)
FINE_ARC_S = 86400.0
FINE_STEP_S = 10.0


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


def _field_ric(model, states, times_tu) -> tuple[np.ndarray, float]:
    """The field's omitted part along states (m, 6) at times_tu on the radial / in-track / cross-track axes about
    the Moon (m, 3), and its RMS (m/s^2)."""
    difference = model.moon_field_difference(states, times_tu)
    ric = np.einsum("kij,kj->ki", _moon_ric(model.moon_relative_states(states, times_tu)), difference)
    return ric, float(np.sqrt(np.mean(np.sum(difference**2, axis=1)))) * M_S2_PER_AU


def hermite_resample(states, times, substeps: int) -> tuple[np.ndarray, np.ndarray]:
    """States (m, 6) at times (m,) resampled `substeps` times per interval by the cubic Hermite interpolant of each
    interval's end positions and velocities (velocities its derivative), in the states' own units:
    ((m - 1) * substeps + 1, 6) and their times."""
    states, times = np.asarray(states, dtype=float), np.asarray(times, dtype=float)
    s = np.arange(substeps) / substeps
    h = np.diff(times)[:, None, None]
    p0, v0, p1, v1 = (x[:, None, :] for x in (states[:-1, :3], states[:-1, 3:], states[1:, :3], states[1:, 3:]))
    s = s[None, :, None]
    position = ((2 * s**3 - 3 * s**2 + 1) * p0 + (s**3 - 2 * s**2 + s) * h * v0 + (-2 * s**3 + 3 * s**2) * p1
                + (s**3 - s**2) * h * v1)
    velocity = ((6 * s**2 - 6 * s) * p0 / h + (3 * s**2 - 4 * s + 1) * v0 + (-6 * s**2 + 6 * s) * p1 / h
                + (3 * s**2 - 2 * s) * v1)
    fine = np.concatenate([position, velocity], axis=2).reshape(-1, 6)
    fine_times = (times[:-1, None] + s[:, :, 0] * h[:, :, 0]).reshape(-1)
    return np.vstack([fine, states[-1:]]), np.append(fine_times, times[-1])


def field_truncation_psd(scenario: Scenario, model, states, times_s) -> float:
    """2 a_rms^2 tau of the Moon's field beyond the filter's degree along the spacecraft's orbit (module
    docstring), m^2/s^3; 0 where the filter's field is the truth's. tau is a property of the orbit, not of the
    data rate: where the measurement epochs resolve it poorly (within RESOLVED_SAMPLES intervals: sparse samples
    alias the field's short features, and a first zero within one interval clipped tau at the interval), it is
    measured again on the nominal orbit every FINE_STEP_S or less (_fine_orbit). Without it, a 50 km orbit's part
    at 600 s was 2.5 to 7 times its part at 60 s (tests/unit/scenario/test_default_noise.py)."""
    if not model.descriptor.lunar_field:
        return 0.0
    k = np.arange(min(len(times_s), MAX_FIELD_SAMPLES))
    states = np.asarray(states, dtype=float)[k]
    times_tu = (np.asarray(times_s, dtype=float)[k] - float(times_s[0])) / TU_S
    ric, rms = _field_ric(model, states, times_tu)
    if rms == 0.0:
        return 0.0
    dt_s, longest_s = float(times_s[1] - times_s[0]), scenario.settle_days() * SECONDS_PER_DAY
    tau_s = correlation_time_s(ric, dt_s, longest_s)
    if tau_s < RESOLVED_SAMPLES * dt_s and dt_s > FINE_STEP_S:
        fine, fine_tu, step_s = _fine_orbit(model, states, times_tu, dt_s)
        fine_ric, fine_rms = _field_ric(model, fine, fine_tu)
        tau_s = correlation_time_s(fine_ric, step_s, longest_s)
        if len(states) < MAX_SAMPLES:  # fewer epochs than an RMS takes elsewhere here (25 a day at 3600 s: -24 %)
            rms = fine_rms
    return 2.0 * rms**2 * tau_s


def _fine_orbit(model, states, times_tu, dt_s: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The nominal orbit (states (m, 6) at times_tu, dt_s apart) on a grid of FINE_STEP_S or less: the first
    FINE_ARC_S interpolated between the epochs (hermite_resample) where no interval sweeps more than
    MAX_INTERPOLATED_ANGLE_RAD about the Moon; else flown again (model.truth_states) over FLOWN_REVOLUTIONS of the
    orbit about the Moon, at most FINE_ARC_S (a cubic across a wider angle cuts inside the orbit: at 3600 s a
    50 km orbit's interpolant passed 430 km below the surface). Returns (states, times_tu, step_s)."""
    about_moon = model.moon_relative_states(states, times_tu)
    rate_per_tu = (np.linalg.norm(np.cross(about_moon[:, :3], about_moon[:, 3:]), axis=1)
                   / np.sum(about_moon[:, :3] ** 2, axis=1))
    swept_rad = rate_per_tu * dt_s / TU_S
    substeps = int(np.ceil(dt_s / FINE_STEP_S))
    if np.max(swept_rad) <= MAX_INTERPOLATED_ANGLE_RAD:
        arc = min(len(states), max(2, int(FINE_ARC_S / dt_s) + 1))
        fine, fine_tu = hermite_resample(states[:arc], times_tu[:arc], substeps)
        return fine, fine_tu, dt_s / substeps
    arc_s = min(FINE_ARC_S, FLOWN_REVOLUTIONS * 2.0 * np.pi * dt_s / float(np.median(swept_rad)))
    fine_tu = times_tu[0] + np.arange(0.0, arc_s + FINE_STEP_S, FINE_STEP_S) / TU_S
    return model.truth_states(states[0], fine_tu), fine_tu, FINE_STEP_S


def default_psd(scenario: Scenario, model, states, times_s, field_psd: float | None = None) -> DefaultNoise:
    """The default PSD of an estimated spacecraft flying states (m, 6) (filter units) at times_s (module
    docstring); field_psd: its field_truncation_psd when already known."""
    parts = {"floor": FLOOR_PSD_M2_S3}
    error = scenario.model_error
    if error.truth_acceleration_sigma_m_s2 > 0.0 and scenario.filter.empirical_acceleration is None:
        parts["model_error random force"] = (2.0 * error.truth_acceleration_sigma_m_s2**2
                                             * error.truth_acceleration_time_constant_s)
    rms = _unmodelled_rms_m_s2(scenario, model, states, times_s)
    if 2.0 * rms**2 * scenario.settle_days() * SECONDS_PER_DAY > NEGLIGIBLE_PSD_M2_S3:
        parts["unmodelled forces"] = 2.0 * rms**2 * scenario.settle_days() * SECONDS_PER_DAY
    if field_psd is None:
        field_psd = field_truncation_psd(scenario, model, states, times_s)
    field = FIELD_PART_FACTOR * field_psd
    if field > NEGLIGIBLE_PSD_M2_S3:
        parts[f"{FIELD_PART_PREFIX} beyond {scenario.moon_gravity.filter_field_label}"] = field
    return DefaultNoise(float(sum(parts.values())), parts)


def linked_spacecraft(scenario: Scenario) -> dict:
    """{participant: the participants it shares a link with} (receiver, transponder and second receiver)."""
    out: dict = {}
    for link in scenario.links:
        ends = [end for end in (link.receiver, link.transponder, link.second_receiver) if end is not None]
        for end in ends:
            out.setdefault(end, set()).update(other for other in ends if other != end)
    return out


def with_field_coupling(defaults: dict, field_psds: dict, linked: dict) -> dict:
    """The defaults {spacecraft: DefaultNoise} with COUPLING_SHARE of each linked spacecraft's omitted-field density
    (field_psds {estimated spacecraft: field_truncation_psd}) added as a part of its own (module docstring); a
    density below the floor is no field error of the linked one's, and passes nothing on."""
    out = {}
    for name, noise in defaults.items():
        parts = dict(noise.parts)
        for other in sorted(linked.get(name, ())):
            if field_psds.get(other, 0.0) >= FLOOR_PSD_M2_S3:
                parts[f"{FIELD_PART_PREFIX} via {other}"] = COUPLING_SHARE * field_psds[other]
        out[name] = DefaultNoise(float(sum(parts.values())), parts)
    return out


def default_noise_line(defaults: dict) -> str:
    """One line for the run text: the spacecraft that take the default and where it came from."""
    phrases = []
    for name, noise in defaults.items():
        parts = " + ".join(f"{what} {q:.2g}" for what, q in noise.parts.items())
        phrases.append(f"{name} {noise.psd_m2_s3:.2g}" + (f" ({parts})" if len(noise.parts) > 1 else ""))
    return (f"process noise: default PSD, m^2/s^3: {'; '.join(phrases)} (the floor for the filter's own "
            "linearisation, plus what the truth holds that the filter does not model; a process-noise key overrides)")
