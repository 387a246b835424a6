"""The whole scenario (`Scenario`): its sections, and the rules that hold between them (names across
sections, observables against participants and noise, estimator against dynamics, time spans, bounded
work). Each section's own rules live with it (participants, links, radio_settings, estimation_settings)."""

from typing import Literal

from pydantic import ConfigDict, Field, model_validator

from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.dynamics.registry import DYNAMICS, Dynamics
from liaison_cli.estimation.estimator import Estimator
from liaison_cli.estimation.estimators import DEFAULT_ESTIMATOR, ESTIMATORS, estimators_that, get_estimator
from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.orbits.departure import MAX_TIME_FROM_PERIAPSIS_S
from liaison_cli.scenario.estimation_settings import (
    BatchSpec, ClockSyncSpec, FilterSpec, InitialErrorSpec, MonteCarloSpec)
from liaison_cli.scenario.exchange_specs import MeasurementFileSpec
from liaison_cli.scenario.links import LinkSpec, MeasurementSpec, TopologySpec, expand_topology
from liaison_cli.scenario.dynamics_rules import (check_dynamics, check_empirical_acceleration,
                                                check_estimated_parameters, check_model_error,
                                                check_ric_process_noise)
from liaison_cli.scenario.model_error import ModelErrorSpec
from liaison_cli.scenario.participants import (
    DATED_ONLY_ORBITS, GEOSTATIONARY_ORBIT, KEPLERIAN_ORBIT, EphemerisSpec, GroundStationSpec, SpacecraftSpec)
from liaison_cli.scenario.radio_settings import NoiseSpec
from liaison_cli.scenario.schema_rules import (
    all_of, any_of, each, equals, given, negate, not_given, schema_rules, together, when)
from liaison_cli.scenario.spec_base import NAME_PATTERN, UNIQUE, StrictModel


# Epochs per run (t0 included): a run holds ~1.0-1.5 kB per epoch (measured peak RSS, 2-3 spacecraft: truth,
# measurements, the filter's histories), so 500,000 epochs stay under ~0.75 GB per worker process; 100x the
# largest shipped scenario (4,609 epochs: 10 d at 187.5 s).
MAX_EPOCHS = 500_000
# The smoother's forward record per run (three n x n matrices per epoch), per worker process: 2 GiB leaves
# room for two workers and the rest of a run on a 24 GiB machine.
SMOOTHER_RECORD_MAX_BYTES = 2 * 2**30
# The JSON Schema's view of the estimators' descriptors: each one's own settings section, and who runs dated.
_OWN_SECTIONS = [(e.name, e.settings_section) for e in ESTIMATORS.values() if e.settings_section is not None]
_UNDATED_ESTIMATORS = [e.name for e in ESTIMATORS.values() if "ephemeris" not in e.dynamics]


class Scenario(StrictModel):
    """A Monte Carlo campaign: who flies where, who measures whom, how the filter runs, how many runs."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        any_of(given("links"), given("topology")),
        *(together(equals("estimator", name), section) for name, section in _OWN_SECTIONS),
        when(equals("dynamics", "ephemeris"),
             all_of(given("ephemeris"), negate(equals("estimator", *_UNDATED_ESTIMATORS)),
                    each("spacecraft", negate(equals("orbit", KEPLERIAN_ORBIT)))),
             all_of(not_given("ephemeris"), each("spacecraft", negate(equals("orbit", *DATED_ONLY_ORBITS))),
                    each("ground_stations", not_given("site")))),
        optional=("links",)))

    name: str = Field(pattern=NAME_PATTERN, description="the result folder's default name (results/<name>); "
                      "letters, digits, '_', '.', '-'")
    description: str = Field("", description="one line for people")
    duration_days: float = Field(gt=0, le=365, description="span from t0 to the last measurement epoch (days)")
    spacecraft: list[SpacecraftSpec] = Field(min_length=1, description="at least one with role: estimated",
                                             json_schema_extra={"contains": negate(equals("role", "known"))})
    ground_stations: list[GroundStationSpec] = Field(default_factory=list, description="stations on the Earth")
    links: list[LinkSpec] = Field(min_length=1, description="who measures whom (or give topology)")
    station_priority: list[str] | None = Field(
        None, description="one ground observation per epoch and spacecraft: of the stations that see it, only the "
        "first measures (003: Goldstone, Madrid, Canberra). Stations not listed rank after the listed ones, in "
        "ground_stations order (a partial list orders the first few; every station still obeys the rule)",
        json_schema_extra=UNIQUE)
    dynamics: Literal[tuple(DYNAMICS)] = Field("crtbp", description="; ".join(
        f"{d.name}: {d.summary}" for d in DYNAMICS.values()))
    ephemeris: EphemerisSpec | None = Field(None, description="dynamics: ephemeris: the epoch and SRP")
    estimator: Literal[tuple(ESTIMATORS)] = Field(DEFAULT_ESTIMATOR, description="; ".join(
        f"{e.name}: {e.summary}" for e in ESTIMATORS.values()))
    batch: BatchSpec | None = Field(None, description="estimator: batch: its span and settings")
    clock_sync: ClockSyncSpec | None = Field(None, description="clock synchronisation by a polynomial fit to "
                                             "dual_one_way_derived clock offsets")
    topology: TopologySpec | None = Field(None, description="star or mesh links, expanded into links when read")
    measurement: MeasurementSpec = Field(description="measurement epochs and the truth's light time")
    noise: NoiseSpec = Field(description="measurement noise and biases of every link (a link's noise overrides)")
    filter: FilterSpec = Field(FilterSpec(), description="the estimator's settings")
    initial_error: InitialErrorSpec = Field(InitialErrorSpec(), description="how each run's initial state error "
                                            "is drawn")
    model_error: ModelErrorSpec = Field(ModelErrorSpec(), description="the filter's dynamics off from the truth's "
                                        "on purpose: C_R and lunar GM, fixed or drawn per run")
    monte_carlo: MonteCarloSpec = Field(description="runs and seed")
    measurements: MeasurementFileSpec | None = Field(None, description="{tdm: FILE}: the filter's measurements from "
                                                     "a TDM, one run (docs/exchange.md)")

    @model_validator(mode="before")
    @classmethod
    def _topology_to_links(cls, data):
        return expand_topology(data) if isinstance(data, dict) else data

    @model_validator(mode="after")
    def _consistent(self):
        names = self.participant_names()
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"participant names must be unique; repeated: {', '.join(dupes)}")
        if not any(sc.role == "estimated" for sc in self.spacecraft):
            raise ValueError("no spacecraft to estimate: give at least one spacecraft with role: estimated")
        self._check_repeated_links()
        known = {sc.name for sc in self.spacecraft if sc.role == "known"} | {st.name for st in self.ground_stations}
        for i, link in enumerate(self.links):
            for role in ("receiver", "transponder", "second_receiver"):
                who = getattr(link, role)
                if who is None:
                    continue
                if who not in names:
                    raise ValueError(
                        f"links[{i}].{role} = {who!r} is not a spacecraft or ground station; defined: {', '.join(names)}"
                    )
            if link.receiver == link.transponder:
                raise ValueError(f"links[{i}] links {link.receiver!r} to itself")
            self._check_second_receiver(i, link, known)
            if link.receiver in known and link.transponder in known and link.second_receiver is None:
                raise ValueError(f"links[{i}] joins two known participants ({link.receiver!r}, {link.transponder!r}): "
                                 "it carries no information on any estimated state")
            receiver = self.participant(link.receiver)
            for observable in link.observables:
                self._check_observable(i, link, observable, receiver)
        self._check_station_priority()
        self._check_estimator()
        self._check_manoeuvres()
        self._check_batch()
        self._check_smoother()
        self._check_initial_batch()
        self._check_clock_sync()
        check_dynamics(self)
        check_model_error(self)
        check_estimated_parameters(self)
        check_empirical_acceleration(self)
        check_ric_process_noise(self)
        if self.measurement.interval_s > self.duration_days * SECONDS_PER_DAY:
            raise ValueError(
                f"measurement.interval_s = {self.measurement.interval_s} is longer than the "
                f"{self.duration_days} d scenario"
            )
        last_epoch_days = (int(self.epochs_end_days() * SECONDS_PER_DAY / self.measurement.interval_s + 1e-9)
                           * self.measurement.interval_s / SECONDS_PER_DAY)
        if self.filter.settle_days is not None and self.filter.settle_days > last_epoch_days:
            raise ValueError(f"filter.settle_days = {self.filter.settle_days:g} leaves no epoch to judge: it must be "
                             f"shorter than the scenario's {self.epochs_end_days():g} d (last epoch at "
                             f"{last_epoch_days:g} d)")
        self._check_epoch_count()
        return self

    def _check_epoch_count(self):
        """Bounded work: refused before anything is allocated (see MAX_EPOCHS)."""
        span_s = self.epochs_end_days() * SECONDS_PER_DAY
        epochs = int(span_s / self.measurement.interval_s + 1e-9) + 1
        if self.filter.smoother == "rts":  # the forward record: 3 (n, n) matrices per epoch, n >= 6 per craft
            n_states = 6 * sum(1 for sc in self.spacecraft if sc.role == "estimated")
            record_bytes = epochs * 3 * n_states**2 * 8
            if record_bytes > SMOOTHER_RECORD_MAX_BYTES:
                raise ValueError(
                    f"filter.smoother = 'rts' over {epochs:,} epochs of {n_states} states keeps "
                    f"{record_bytes / 2**30:.1f} GiB per run; allowed: at most {SMOOTHER_RECORD_MAX_BYTES / 2**30:g} "
                    "GiB (a longer measurement.interval_s, a shorter duration_days, or no smoother)")
        if epochs > MAX_EPOCHS:
            raise ValueError(
                f"measurement.interval_s = {self.measurement.interval_s:g} over duration_days = "
                f"{self.duration_days:g} is {epochs:,} epochs per run; allowed: at most {MAX_EPOCHS:,} (about "
                f"1.5 kB of memory each): measurement.interval_s >= {span_s / (MAX_EPOCHS - 1):.4g} s for this "
                "duration, or a shorter duration_days")

    def _check_smoother(self):
        """The RTS pass smooths the EKF's own forward record: no batch, no consider parameters (their zero-gain
        covariance is not the record of an optimal filter) and no manoeuvre (its jump is not in the stored
        transitions)."""
        if self.filter.smoother == "none":
            return
        if not self.estimator_descriptor().smoother:
            raise ValueError(f"filter.smoother = 'rts' smooths a filter's pass; estimator: {self.estimator} takes no "
                             f"smoother (allowed with estimator: {' / '.join(estimators_that('smoother'))})")
        if self.filter.bias == "consider":
            raise ValueError("filter.smoother = 'rts' with filter.bias = 'consider': not supported (estimate or "
                             "ignore the bias)")
        if self.filter.underweighting > 0:
            raise ValueError(f"filter.smoother = 'rts' with filter.underweighting = {self.filter.underweighting:g}: "
                             "the RTS recursion assumes the optimal gain; allowed: underweighting 0 with the smoother")
        moving = [sc.name for sc in self.spacecraft if sc.manoeuvre is not None]
        if moving:
            raise ValueError(f"filter.smoother = 'rts' with a manoeuvre ({moving[0]!r}): not supported")

    def dynamics_descriptor(self) -> Dynamics:
        """The chosen dynamics model's descriptor: what it is and supports (dynamics.registry)."""
        return DYNAMICS[self.dynamics]

    def estimator_descriptor(self) -> Estimator:
        """The chosen estimator's descriptor: what it carries and supports (estimation.estimator)."""
        return get_estimator(self.estimator)

    def _check_estimator(self):
        """What the chosen estimator carries and supports, asked of its descriptor: its own settings section
        (given exactly when it is chosen), clock-timed observables, considered biases, the residual gate."""
        for name, section in _OWN_SECTIONS:
            given_section = getattr(self, section) is not None
            if (self.estimator == name) != given_section:
                raise ValueError(f"key 'estimator' = {self.estimator!r} "
                                 f"{'with' if given_section else 'without'} a '{section}' section: estimator: {name} "
                                 f"and a '{section}' section go together (give both or neither)")
        estimator = self.estimator_descriptor()
        if not estimator.carries_clocks:
            self._check_no_clock_states(estimator)
        if self.filter.bias == "estimate" and not estimator.carries_biases:
            raise ValueError(f"filter.bias = 'estimate' with estimator: {self.estimator}, which carries no bias "
                             f"states; allowed with estimator: {' / '.join(estimators_that('carries_biases'))}")
        if self.filter.bias == "consider" and not estimator.consider:
            raise ValueError(f"filter.bias = 'consider' with estimator: {self.estimator}, which has no consider "
                             f"treatment (it would estimate the bias); allowed: bias estimate or ignore, or estimator: "
                             f"{' / '.join(estimators_that('consider'))}")
        if self.filter.residual_gate_sigma is not None and not estimator.residual_gate:
            raise ValueError(f"filter.residual_gate_sigma = {self.filter.residual_gate_sigma:g} gates the EKF's "
                             f"pre-fit innovations; the {self.estimator} estimator (estimator: {self.estimator}) has "
                             "no residual gate: remove the key or use estimator: "
                             f"{' / '.join(estimators_that('residual_gate'))}")

    def _check_no_clock_states(self, estimator: Estimator):
        for i, link in enumerate(self.links):
            for observable in link.observables:
                spec = OBSERVABLES[observable]
                if spec.needs_receiver_clock or any(
                        spec.channel_clock_coefficients(c) != (0.0, 0.0) and c != spec.clock_offset_channel
                        for c in range(len(spec.channels))):
                    raise ValueError(f"links[{i}] measures {observable!r}, whose value carries clock states: the "
                                     f"{estimator.name} estimator solves for orbits only; use dual_one_way_derived "
                                     "(range + clock offset, synchronised by clock_sync) or the "
                                     f"{' / '.join(estimators_that('carries_clocks'))}")

    def _check_initial_batch(self):
        """The initial batch window: at least two measurement intervals, inside the scenario, before any
        manoeuvre (the window's solve has no burn), and only in front of an EKF without a smoother or consider
        parameters (the smoother would smooth only the EKF's part; consider blocks would be solved for)."""
        flt = self.filter
        if flt.initial_batch_hours is None:
            return
        longest_h = flt.initial_batch_max_hours or flt.initial_batch_hours
        shortest_h = 2.0 * self.measurement.interval_s / 3600.0
        if flt.initial_batch_hours < shortest_h - 1e-9:
            raise ValueError(f"filter.initial_batch_hours = {flt.initial_batch_hours:g} is shorter than two "
                             f"measurement intervals; allowed: at least {shortest_h:g} h")
        scenario_h = self.epochs_end_days() * 24.0
        if longest_h >= scenario_h - self.measurement.interval_s / 3600.0 + 1e-9:
            key = "initial_batch_max_hours" if flt.initial_batch_max_hours else "initial_batch_hours"
            raise ValueError(f"filter.{key} = {longest_h:g} leaves the EKF no data: allowed: shorter than the "
                             f"scenario's {scenario_h:g} h less one measurement interval")
        if not self.estimator_descriptor().initial_batch:
            raise ValueError(f"filter.initial_batch_hours with estimator: {self.estimator}: not supported (allowed "
                             f"with estimator: {' / '.join(estimators_that('initial_batch'))})")
        if flt.smoother != "none":
            raise ValueError("filter.initial_batch_hours with filter.smoother = 'rts': not supported (the smoother "
                             "would cover only the EKF's part of the arc)")
        if flt.bias == "consider":
            raise ValueError("filter.initial_batch_hours with filter.bias = 'consider': not supported (the batch "
                             "would solve for the considered bias)")
        for i, sc in enumerate(self.spacecraft):
            if sc.manoeuvre is not None and sc.manoeuvre.epoch_days * 24.0 < longest_h + 1e-9:
                raise ValueError(f"spacecraft[{i}].manoeuvre.epoch_days = {sc.manoeuvre.epoch_days:g} falls inside "
                                 f"the initial batch window ({longest_h:g} h); allowed: after it")

    def _check_batch(self):
        """The batch section's spans against the scenario's epochs."""
        if self.batch is None:
            return
        end_days = self.batch.end_days()
        if end_days > self.duration_days + 1e-9:
            windows = f" over {self.batch.windows} windows" if self.batch.windows > 1 else ""
            raise ValueError(f"batch.span_days = {self.batch.span_days:g} plus prediction_hours = "
                             f"{self.batch.prediction_hours:g}{windows} is {end_days:g} d, longer than the "
                             f"scenario's duration_days = {self.duration_days:g}")
        if self.batch.renewal_hours is not None and (
                abs(self.batch.renewal_hours * 3600.0 / self.measurement.interval_s
                    - round(self.batch.renewal_hours * 3600.0 / self.measurement.interval_s)) > 1e-9):
            raise ValueError(f"batch.renewal_hours = {self.batch.renewal_hours:g} is not a whole number of "
                             f"measurement intervals ({self.measurement.interval_s:g} s)")
        if self.batch.span_days * SECONDS_PER_DAY < 2.0 * self.measurement.interval_s:
            raise ValueError(f"batch.span_days = {self.batch.span_days:g} is shorter than two measurement "
                             f"intervals ({self.measurement.interval_s:g} s)")

    def _check_second_receiver(self, i, link, known):
        """Three-end channels (TDoA, FDoA) and the links that carry them."""
        differences = [o for o in link.observables if OBSERVABLES[o].needs_second_receiver]
        if differences and link.second_receiver is None:
            raise ValueError(f"links[{i}] measures {differences[0]!r}, a difference between two receivers, with one "
                             f"receiver ({link.receiver!r}): give 'second_receiver'")
        if link.second_receiver is None:
            return
        others = [o for o in link.observables if not OBSERVABLES[o].needs_second_receiver]
        if others:
            raise ValueError(f"links[{i}] has a second_receiver, but {others[0]!r} is a two-end observable; "
                             "a link with a second receiver carries tdoa / fdoa only")
        if link.second_receiver == link.transponder:
            raise ValueError(f"links[{i}]: {link.transponder!r} is the transmitter and also a receiver")
        if link.second_receiver == link.receiver:
            raise ValueError(f"links[{i}] names {link.receiver!r} as both receivers")
        if {link.receiver, link.transponder, link.second_receiver} <= known:
            raise ValueError(f"links[{i}] joins three known participants: it carries no information on any "
                             "estimated state")

    def _check_manoeuvres(self):
        for i, sc in enumerate(self.spacecraft):
            if sc.manoeuvre is None:
                continue
            if not self.estimator_descriptor().carries_manoeuvres:
                solvers = " / ".join(estimators_that("carries_manoeuvres"))
                raise ValueError(f"spacecraft[{i}].manoeuvre: the {solvers} solves for manoeuvres (estimator: "
                                 f"{solvers}); estimator: {self.estimator} does not")
            last = self.duration_days - self.measurement.interval_s / SECONDS_PER_DAY
            if not sc.manoeuvre.epoch_days <= last + 1e-9:
                raise ValueError(f"spacecraft[{i}].manoeuvre.epoch_days = {sc.manoeuvre.epoch_days:g} is outside the "
                                 f"scenario: allowed after 0 and up to {last:g} d (one interval before its end)")

    def _check_repeated_links(self):
        """The same measurement listed twice would be counted twice (as if its noise were halved). A link is
        its ends in their roles; a difference of arrival is the same with its two receivers swapped (the
        negated value). The reverse direction (B receiving from A beside A from B) is another link."""
        seen = {}
        for i, link in enumerate(self.links):
            if link.second_receiver is None:
                ends = (link.receiver, link.transponder)
            else:
                ends = (link.transponder, frozenset((link.receiver, link.second_receiver)))
            if ends in seen:
                j = seen[ends]
                second = f", second_receiver {link.second_receiver}" if link.second_receiver else ""
                raise ValueError(f"links[{i}] repeats links[{j}] (receiver {link.receiver}, transponder "
                                 f"{link.transponder}{second}): it would count the same measurement twice; "
                                 f"allowed: one link per set of ends, with all its observables in links[{j}]")
            seen[ends] = i

    def _check_station_priority(self):
        if self.station_priority is None:
            return
        stations = [st.name for st in self.ground_stations]
        for i, name in enumerate(self.station_priority):
            if name not in stations:
                raise ValueError(f"station_priority[{i}] = {name!r} is not a ground station; defined: "
                                 f"{', '.join(stations) or 'none'}")
        if len(set(self.station_priority)) != len(self.station_priority):
            raise ValueError(f"station_priority lists a station twice: {self.station_priority}")

    def _check_clock_sync(self):
        if self.clock_sync is None:
            return
        window_s = self.clock_sync.window_hours * 3600.0
        if window_s < 2.0 * self.measurement.interval_s:
            raise ValueError(f"clock_sync.window_hours = {self.clock_sync.window_hours:g} is shorter than two "
                             f"measurement intervals ({self.measurement.interval_s:g} s)")
        if not any(OBSERVABLES[o].clock_offset_channel >= 0 for link in self.links for o in link.observables):
            raise ValueError("clock_sync needs a link that measures clock offsets (observable dual_one_way_derived)")

    def cr_error_sigma(self) -> float:
        """The per-run relative sigma of the filter's C_R: model_error.cr_sigma or ephemeris.cr_error_sigma."""
        older = self.ephemeris.cr_error_sigma if self.ephemeris is not None else 0.0
        return self.model_error.cr_sigma or older

    def filter_range_model(self) -> str:
        """filter.range_model, or, when absent, the truth's: light_time when measurement.light_time, else
        geometric (the filter matches the truth unless the scenario names the paper's geometric model)."""
        if self.filter.range_model is not None:
            return self.filter.range_model
        return "light_time" if self.measurement.light_time else "geometric"

    def settle_days(self) -> float:
        """filter.settle_days, or its default: 1 d, or half the scenario's epochs when they span less than 2 d."""
        if self.filter.settle_days is not None:
            return self.filter.settle_days
        return min(1.0, 0.5 * self.epochs_end_days())

    def data_end_days(self) -> float:
        """Where the estimator's data end: the batch span, else the whole scenario."""
        return self.batch.span_days if self.batch is not None else self.duration_days

    def epochs_end_days(self) -> float:
        """Where the scenario's epochs end: span + prediction for a batch, else duration_days."""
        if self.batch is None:
            return self.duration_days
        return min(self.duration_days, self.batch.end_days())

    def _check_observable(self, i, link, observable, receiver):
        spec = OBSERVABLES[observable]
        if spec.needs_receiver_baseline and getattr(receiver, "antenna_baseline_m", None) is None:
            raise ValueError(
                f"links[{i}] cannot measure {observable!r}: its receiver {link.receiver!r} has no antenna "
                "array (set antenna_baseline_m on that spacecraft)"
            )
        missing = spec.missing_noise(link.noise.applied_to(self.noise) if link.noise is not None else self.noise)
        if missing:
            raise ValueError(f"links[{i}] measures {observable}: {missing}")
        if spec.needs_both_clocks:
            for who in (link.receiver, link.transponder):
                if getattr(self.participant(who), "clock", None) is None:
                    raise ValueError(f"links[{i}] measures {observable!r}, timed by both ends' clocks, but "
                                     f"{who!r} has no clock model (give it a 'clock' section)")
        if spec.needs_receiver_clock and getattr(receiver, "clock", None) is None:
            raise ValueError(f"links[{i}] measures {observable!r}, timed by the receiver's clock, but "
                             f"{link.receiver!r} has no clock (give that spacecraft a 'clock' section)")

    def spacecraft_names(self) -> list[str]:
        """The estimated spacecraft, in scenario order (the filter's spacecraft blocks)."""
        return [sc.name for sc in self.spacecraft if sc.role == "estimated"]

    def participant_names(self) -> list[str]:
        return [sc.name for sc in self.spacecraft] + [st.name for st in self.ground_stations]

    def participant(self, name: str):
        return next(p for p in [*self.spacecraft, *self.ground_stations] if p.name == name)

