"""Scenario estimation settings: the filter section, the batch estimator's, clock synchronisation, how each
run's initial error is drawn, and the Monte Carlo runs and seed."""

from typing import Annotated, ClassVar, Literal

from pydantic import ConfigDict, Field, model_validator

from liaison_cli.dynamics.registry import DYNAMICS
from liaison_cli.dynamics.step_choice import DEFAULT_TOLERANCE_M
from liaison_cli.scenario.schema_rules import Rule, at_least, check_rules, equals, given, schema_rules, when
from liaison_cli.scenario.spec_base import ONE_PROCESS_NOISE_CONVENTION, RicDensities, StrictModel


# The two process-noise conventions (FilterSpec.process_noise_of; estimation.process_noise): the filter key
# each is given by, and the unit of its value.
PROCESS_NOISE_PSD = "process_noise_psd_m2_s3"
PROCESS_NOISE_PSD_RIC = "process_noise_psd_ric_m2_s3"
PROCESS_NOISE_SIGMA_A = "process_noise_accel_m_s2"
PROCESS_NOISE_UNITS = {PROCESS_NOISE_PSD: "m^2/s^3", PROCESS_NOISE_PSD_RIC: "m^2/s^3", PROCESS_NOISE_SIGMA_A: "m/s^2"}
RIC_PSD_DESCRIPTION = (
    "SNC as a power spectral density per axis of the spacecraft's radial / in-track / cross-track frame [q_R, "
    "q_I, q_C], the frame taken at the estimate at each step about the nearer primary (as the run's RIC "
    "columns): Q = sum over the axes u of q_u [[dt^3/3, dt^2/2], [dt^2/2, dt]] u u'; the EKF only, without an "
    "initial batch. Not with the other two process-noise keys (m^2/s^3)")


MAX_RUNS = 1_000_000  # Monte Carlo runs per scenario or grid point: the YAML and --runs share this cap


# The residual gate's warm-up (FilterSpec.residual_gate_after), by default none: the gate applies from the
# first measurement. Its spread sqrt(H P H' + R) carries the a-priori covariance, so the gate is wide while
# the filter is uncertain and the a-priori transient is not edited away: measured at 5 sigma from the first
# measurement, no clean measurement of any shipped scenario is rejected (2 runs each; the 004 cases from
# their 1,000 km / 100 m/s a priori included). A warm-up, on the other hand, lets its outliers through, and
# one accepted outlier can move the estimate beyond the gate, which then refuses the good data after it:
# eml2_lunar with 1 % of measurements at 100 sigma, 10 runs, mean EML2 position RMS 647 m with no warm-up,
# 819 m after 50, 26 km after 100 (one run edited 97.5 % of its data). A warm-up is for a P0 that
# understates the initial error: with an initial error 20x P0 the gate from the first measurement locks out
# (90 % of clean data rejected, 7 of 10 runs diverged); 200 accepted measurements were needed there.
GATE_AFTER_DEFAULT = 0


class EmpiricalAccelerationSpec(StrictModel):
    """filter.empirical_acceleration: a first-order Gauss-Markov acceleration per estimated spacecraft, three
    states on the dynamics model's axes (dynamic model compensation; estimation.process_noise)."""

    # At least 1e-12 m/s^2 (issue 47: 1e-300 made its variance underflow to zero in filter units, and every run
    # of a healthy scenario stop as 'covariance not positive'); far below any force a filter would model.
    sigma_m_s2: float = Field(..., ge=1e-12, le=1e-5, description="its steady-state 1-sigma per axis, which is also "
                              "its a priori (the SRP on a 0.01 m^2/kg cannonball is ~7e-8), at least 1e-12 (m/s^2)")
    time_constant_s: float = Field(..., gt=0, description="its correlation time tau: the acceleration decays as "
                                   "exp(-t / tau) between updates; at least measurement.interval_s (shorter is "
                                   "white noise: use the process noise) (s)")


class FilterSpec(StrictModel):
    """The estimator's settings: a priori, process noise, health checks, the filter's measurement models."""

    RULES: ClassVar[tuple] = (Rule(when(equals("bias", "estimate", "consider"), given("bias_apriori_sigma_m")),
                  lambda spec: f"bias {spec.bias!r} needs 'bias_apriori_sigma_m' (the a-priori 1-sigma, m)"),
             ONE_PROCESS_NOISE_CONVENTION)
    model_config = ConfigDict(json_schema_extra=schema_rules(*RULES))

    initial_sigma_position_m: float = Field(1000.0, gt=0, description="a-priori 1-sigma per position axis (m)")
    initial_sigma_velocity_m_s: float = Field(0.01, gt=0, description="a-priori 1-sigma per velocity axis (m/s)")
    process_noise_psd_m2_s3: float | None = Field(
        None, ge=0, description="SNC as a power spectral density q of a continuous white acceleration, the same on "
        "every axis of every frame (isotropic: inertial and radial / in-track / cross-track alike; a PSD per RIC "
        "axis: process_noise_psd_ric_m2_s3), for every spacecraft (a spacecraft's own key overrides it): Q = q [[dt^3/3, dt^2/2], "
        "[dt^2/2, dt]] per axis, so the noise per day does not depend on measurement.interval_s. Not with "
        "process_noise_accel_m_s2; neither given (here or on the spacecraft): a PSD derived for the scenario, a "
        "floor of 3e-18 plus what the truth holds that the filter does not model (scenario.default_noise) "
        "(m^2/s^3)")
    process_noise_accel_m_s2: float | None = Field(
        None, ge=0, description="per-step sigma_a: q = sigma_a^2 dt, dt the measurement interval — the convention "
        "of 001/003/004's reproductions (the noise per day grows with measurement.interval_s), for every "
        "spacecraft (a spacecraft's own key overrides it). Not with process_noise_psd_m2_s3 (m/s^2)")
    process_noise_psd_ric_m2_s3: RicDensities | None = Field(
        None, description=RIC_PSD_DESCRIPTION + "; for every spacecraft (a spacecraft's own key overrides it)")
    process_noise_model: Literal["continuous_white_acceleration", "velocity_only"] = Field(
        "continuous_white_acceleration", description="how a per-step sigma_a becomes Q per step dt: continuous "
        "white acceleration (q = sigma_a^2 dt; Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]] per axis) or (sigma_a dt)^2 "
        "on the velocities only (the form before issue 26). A PSD (process_noise_psd_m2_s3, here or per "
        "spacecraft) always takes the continuous form")
    divergence_position_km: float = Field(1e4, gt=0, description="a run whose position error exceeds this is "
                                          "stopped as diverged (km)")
    divergence_nees_factor: float = Field(
        100.0, ge=1, description="a run whose NEES stays above this many times its 99.9 % chi-square quantile "
        "for divergence_window_days is diverged (dimensionless)")
    divergence_window_days: float = Field(1.0, gt=0, description="see divergence_nees_factor (days)")
    rk4_substeps: int | None = Field(None, ge=1, le=256, description="steps of the filter's integrator (RK4; "
                                     "RK8 with dynamics: ephemeris) per measurement interval, for every spacecraft; "
                                     "absent: chosen per spacecraft by accuracy (integration_tolerance_m) (count)")
    integration_tolerance_m: float = Field(
        DEFAULT_TOLERANCE_M, gt=0, le=1000, description="without rk4_substeps: each spacecraft's substeps are the "
        "fewest (at least 4) whose one-interval error along the nominal trajectory, position or velocity x "
        "interval, stays within this (dynamics.step_choice) (m)")
    range_model: Literal["geometric", "light_time"] | None = Field(
        None, description="the filter's range model: light_time (each path with its light time, tagged at "
        "reception as the truth is) or geometric (001 Eq. 17: the instantaneous distance at the reception epoch; "
        "it lags a light-time truth by about the one-way light time). Absent: the truth's model "
        "(measurement.light_time), so the filter is matched unless a scenario names the paper's geometric model"
    )
    bias: Literal["ignore", "estimate", "consider"] = Field(
        "ignore", description="range bias per link: not modelled, estimated (augmented state) or considered"
    )
    bias_apriori_sigma_m: float | None = Field(None, gt=0, description="a-priori 1-sigma of each link's bias (m)")
    underweighting: float = Field(
        0.0, ge=0, le=10, description="Lear's underweighting beta of the EKF gain, K = P H' ((1+beta) H P H' + R)^-1: "
        "keeps a large a-priori error from being corrected on a linearisation not yet good (e.g. 0.2) "
        "(dimensionless)")
    settle_days: float | None = Field(
        None, ge=0, description="time after t0 from which consistency is judged (error RMS against sigma RMS, NEES "
        "in its 95 % band): the a-priori transient is left out. Default (absent): 1 d, or half the scenario when it "
        "is shorter than 2 d. From the papers' a priori (1 km, 1 cm/s) the halo and lunar filters settle within "
        "the first day, and 1 d keeps the after-day-1 columns' meaning (days)")
    residual_gate_sigma: float | None = Field(
        None, gt=0, description="EKF residual editing (unit: standard deviations of the innovation): a scalar "
        "measurement whose pre-fit innovation exceeds this many sqrt(H P H' + R) is rejected (no update) and "
        "counted; absent or null: no gate. 5 rejects 5.7e-7 of clean Gaussian data, 3 rejects 0.27 % (sigma)")
    residual_gate_after: int = Field(
        GATE_AFTER_DEFAULT, ge=0, le=10**9, description="the gate applies once the filter has accepted this many "
        "measurements (unit: scalar measurements, all links together); default 0: from the first, the a-priori "
        "spread being part of the gate's; raise it only for a P0 that understates the initial error (count)")
    smoother: Literal["none", "rts"] = Field(
        "none", description="rts: also run the Rauch-Tung-Striebel fixed-interval smoother over each EKF pass "
        "(smoothed errors and sigma in the outputs: 003's reconstructed trajectory); keeps three n x n matrices "
        "per epoch in memory while a run is smoothed")
    initial_batch_hours: float | None = Field(
        None, gt=0, description="start the EKF from a batch least-squares solution (with the a priori as "
        "information) over the first this many hours of data, handed over with its covariance at the window's "
        "end; the EKF takes the measurements after it. For an a priori too poor for the EKF's first updates "
        "(004's 1,000 km and 100 m/s per axis). Absent: the EKF starts from the a priori at t0 (h)")
    initial_batch_max_hours: float | None = Field(
        None, gt=0, description="the batch window doubles from initial_batch_hours up to this many hours until "
        "the hand-over position 1-sigma (RSS) is below initial_batch_handover_sigma_km; absent: the window stays "
        "at initial_batch_hours (h)")
    initial_batch_handover_sigma_km: float = Field(
        10.0, gt=0, description="hand over to the EKF once every spacecraft's position 1-sigma (RSS) at the "
        "window's end is below this (or the window has reached initial_batch_max_hours) (km)")
    initial_batch_max_iterations: int = Field(
        30, ge=1, le=1000, description="Gauss-Newton iterations per batch window at most (count)")
    estimated_parameters: dict[str, Annotated[float, Field(gt=0, le=0.5)]] = Field(
        default_factory=dict, description="dynamics-model parameters the filter carries as states, each with its "
        "a-priori 1-sigma (at most 0.5, so that the flown value stays positive): {cr: 0.1} estimates one "
        "relative correction to the C_R of every spacecraft (dynamics: ephemeris has one C_R A/m for all; the "
        "filter flies C_R (1 + state), a priori 0 +- 0.1). What each dynamics model offers: docs/filter.md "
        "(dimensionless)",
        json_schema_extra={"propertyNames": {"enum": sorted({p.name for d in DYNAMICS.values() for p in d.parameters})}})

    empirical_acceleration: EmpiricalAccelerationSpec | None = Field(
        None, description="estimate a first-order Gauss-Markov acceleration per estimated spacecraft (dynamic "
        "model compensation: three states on the dynamics model's axes, crtbp: the rotating frame, ephemeris: "
        "ICRF; docs/filter.md), beside the process noise; absent: none")

    @model_validator(mode="after")
    def _batch_window_order(self):
        if (self.initial_batch_max_hours is not None and self.initial_batch_hours is not None
                and self.initial_batch_max_hours < self.initial_batch_hours):
            raise ValueError(f"initial_batch_max_hours = {self.initial_batch_max_hours:g} is shorter than "
                             f"initial_batch_hours = {self.initial_batch_hours:g}: allowed: at least as long")
        if self.initial_batch_max_hours is not None and self.initial_batch_hours is None:
            raise ValueError("initial_batch_max_hours needs initial_batch_hours (the first window)")
        return self

    @model_validator(mode="after")
    def _rules(self):
        return check_rules(self, self.RULES)

    def process_noise_of(self, spacecraft) -> tuple[str, float | tuple | None]:
        """(PROCESS_NOISE_PSD, q in m^2/s^3), (PROCESS_NOISE_PSD_RIC, (q_R, q_I, q_C) in m^2/s^3) or
        (PROCESS_NOISE_SIGMA_A, sigma_a in m/s^2) for a spacecraft: its own key, else the filter's; neither
        given: (PROCESS_NOISE_PSD, None), the PSD derived for the scenario at setup (scenario.default_noise)."""
        for section in (spacecraft, self):
            for key in (PROCESS_NOISE_PSD, PROCESS_NOISE_PSD_RIC, PROCESS_NOISE_SIGMA_A):
                if getattr(section, key) is not None:
                    return key, getattr(section, key)
        return PROCESS_NOISE_PSD, None

    def uses_ric_process_noise(self, spacecraft_list) -> bool:
        """Whether an estimated spacecraft of the list takes its process noise per RIC axis."""
        return any(self.process_noise_of(sc)[0] == PROCESS_NOISE_PSD_RIC for sc in spacecraft_list
                   if sc.role == "estimated")


class BatchSpec(StrictModel):
    """The batch least-squares estimator (estimator: batch, 002 §3): one solve for the epoch state from the
    measurements of the first `span_days`, predicted `prediction_hours` past the span (002's DRMS window).
    The scenario's epochs end at span + prediction (duration_days must cover them)."""

    RULES: ClassVar[tuple] = (Rule(when(at_least("windows", 2), given("renewal_hours")),
                  lambda spec: f"windows = {spec.windows} needs 'renewal_hours' (the spacing of window starts)"),)
    model_config = ConfigDict(json_schema_extra=schema_rules(*RULES))

    span_days: float = Field(gt=0, description="data span of the solve, from t0 (days)")
    prediction_hours: float = Field(3.0, ge=0, description="prediction after the span for the DRMS metrics (h)")
    max_iterations: int = Field(10, ge=1, le=100, description="Gauss-Newton iterations at most (count)")
    tolerance_m: float = Field(1e-3, gt=0, description="converged when no position correction exceeds this (m)")
    apriori: bool = Field(False, description="add the filter's initial covariance as a-priori information")
    jacobian: Literal["first_iteration", "every_iteration"] = Field(
        "first_iteration", description="STM from the first iteration's reference (frozen) or recomputed each time")
    windows: int = Field(1, ge=1, le=1000, description="sliding windows, each span_days long (count)")
    renewal_hours: float | None = Field(None, gt=0, description="window start spacing, a whole number of "
                                        "measurement intervals (needed with windows > 1) (h)")

    @model_validator(mode="after")
    def _renewal(self):
        check_rules(self, self.RULES)
        if self.renewal_hours is not None and self.renewal_hours / 24.0 > self.span_days:
            raise ValueError(f"renewal_hours = {self.renewal_hours:g} is longer than the span ({self.span_days:g} d): "
                             "windows would leave data unused")
        return self

    def end_days(self) -> float:
        """The last window's span end plus its prediction."""
        renewal_days = (self.renewal_hours or 0.0) / 24.0
        return (self.windows - 1) * renewal_days + self.span_days + self.prediction_hours / 24.0


class ClockSyncSpec(StrictModel):
    """Synchronisation by a polynomial fit to the clock offsets of dual one-way links (002 §4), over a window
    ending at the end of the data span (the batch span, else the scenario's end), then predicted."""

    window_hours: float = Field(3.0, gt=0, description="length of the fit window, at least two measurement "
                                "intervals (h)")
    prediction_hours: float = Field(3.0, ge=0, description="prediction after the window (h)")
    degree: int = Field(2, ge=0, le=3, description="polynomial degree, 2: a0 + a1 (t - t0) + a2 (t - t0)^2 "
                        "(dimensionless)")


class InitialErrorSpec(StrictModel):
    """`from_covariance` (default): drawn from the filter's own P0, so that the filter's sigma describes its
    error from the first epoch; `fixed_sigma`: independent normal errors with the sigmas below (001's Monte
    Carlo: 500 m and 1 mm/s under a P0 of 1 km and 1 cm/s, a filter pessimistic by design)."""

    draw: Literal["fixed_sigma", "from_covariance"] = Field("from_covariance", description="from_covariance: the "
                                                            "filter's P0; fixed_sigma: the sigmas below (the "
                                                            "paper's draw)")
    sigma_position_m: float = Field(500.0, ge=0, description="fixed_sigma: 1-sigma per position axis (m)")
    sigma_velocity_m_s: float = Field(0.001, ge=0, description="fixed_sigma: 1-sigma per velocity axis (m/s)")


class OutputSpec(StrictModel):
    """Optional tables beyond the default ones (docs/outputs.md)."""

    epoch_states_runs: int = Field(0, ge=0, le=MAX_RUNS, description="states.parquet: per-epoch estimate, error "
                                   "and sigma (model axes and radial / in-track / cross-track) and the position and "
                                   "velocity correlations per spacecraft, for runs 0 .. N-1 at up to 1,000 epochs "
                                   "each; 0: no such table; `liaison run --epoch-states` overrides (count)")


class MonteCarloSpec(StrictModel):
    """How many runs, and the seed every run's random numbers derive from (with the run index)."""

    runs: int = Field(ge=1, le=MAX_RUNS, description="Monte Carlo runs; `liaison run --runs` overrides (count)")
    seed: int = Field(ge=0, description="master seed; a run's numbers depend on (scenario, seed, run index) only "
                      "(integer)")
