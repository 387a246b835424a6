"""The whole scenario (`Scenario`): its sections, and the rules that hold between them. Each section's own rules
live with it (participants, links, radio_settings, estimation_settings); the rules between sections are grouped
by the part that owns them: the links' in scenario.link_rules, the estimator's in scenario.estimation_rules, the
dynamics model's in scenario.dynamics_rules; names across sections, time spans, manoeuvres and bounded work
stay here."""

from typing import Literal

from pydantic import ConfigDict, Field, model_validator

from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.dynamics.registry import DYNAMICS, Dynamics
from liaison_cli.estimation.estimator import Estimator
from liaison_cli.estimation.estimators import DEFAULT_ESTIMATOR, ESTIMATORS, estimators_that, get_estimator
from liaison_cli.scenario.estimation_settings import (
    BatchSpec, ClockSyncSpec, FilterSpec, InitialErrorSpec, MonteCarloSpec, OutputSpec)
from liaison_cli.scenario.estimation_rules import (OWN_SECTIONS, check_batch_section, check_clock_sync, check_estimator,
                                                   check_initial_batch, check_smoother)
from liaison_cli.scenario.exchange_specs import MeasurementFileSpec
from liaison_cli.scenario.link_rules import (check_observable, check_repeated_links, check_second_receiver,
                                             check_station_priority)
from liaison_cli.scenario.links import LinkSpec, MeasurementSpec, TopologySpec, expand_topology
from liaison_cli.scenario.dynamics_rules import (check_dynamics, check_empirical_acceleration,
                                                check_estimated_parameters, check_model_error,
                                                check_dead_process_noise, check_ric_process_noise)
from liaison_cli.scenario.model_error import ModelErrorSpec
from liaison_cli.scenario.moon_gravity import MoonGravitySpec
from liaison_cli.scenario.participants import (
    DATED_ONLY_ORBITS, EphemerisSpec, GroundStationSpec, SpacecraftSpec)
from liaison_cli.scenario.radio_settings import NoiseSpec
from liaison_cli.scenario.schema_rules import (
    all_of, any_of, each, equals, given, negate, not_given, schema_rules, together, when)
from liaison_cli.scenario.spec_base import NAME_MAX_LENGTH, NAME_PATTERN, UNIQUE, StrictModel


# Epochs per run (t0 included): a run holds ~1.0-1.5 kB per epoch (measured peak RSS, 2-3 spacecraft: truth,
# measurements, the filter's histories), so 500,000 epochs stay under ~0.75 GB per worker process; 100x the
# largest shipped scenario (4,609 epochs: 10 d at 187.5 s).
MAX_EPOCHS = 500_000
# The smoother's forward record per run (three n x n matrices per epoch), per worker process: 2 GiB leaves
# room for two workers and the rest of a run on a 24 GiB machine.
SMOOTHER_RECORD_MAX_BYTES = 2 * 2**30
# The JSON Schema's view of the estimators' descriptors: who runs dated (their own sections: OWN_SECTIONS).
_UNDATED_ESTIMATORS = [e.name for e in ESTIMATORS.values() if "ephemeris" not in e.dynamics]


class Scenario(StrictModel):
    """A Monte Carlo campaign: who flies where, who measures whom, how the filter runs, how many runs."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        any_of(given("links"), given("topology")),
        *(together(equals("estimator", name), section) for name, section in OWN_SECTIONS),
        when(equals("dynamics", "ephemeris"),
             all_of(given("ephemeris"), negate(equals("estimator", *_UNDATED_ESTIMATORS))),
             all_of(not_given("ephemeris"), each("spacecraft", negate(equals("orbit", *DATED_ONLY_ORBITS))),
                    each("ground_stations", not_given("site")))),
        optional=("links",)))

    name: str = Field(pattern=NAME_PATTERN, max_length=NAME_MAX_LENGTH, description="the result folder's default "
                      f"name (results/<name>); letters, digits, '_', '.', '-'; at most {NAME_MAX_LENGTH} characters")
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
    moon_gravity: MoonGravitySpec | None = Field(None, description="the Moon's gravity field (GRGM1200A) to a "
                                                 "degree, in the truth and in the filter; absent: a point-mass Moon")
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
    output: OutputSpec = Field(OutputSpec(), description="optional tables: per-epoch states and covariance")
    measurements: MeasurementFileSpec | None = Field(None, description="{tdm: FILE}: the filter's measurements from "
                                                     "a TDM, one run (docs/exchange.md)")

    @model_validator(mode="before")
    @classmethod
    def _topology_to_links(cls, data):
        return expand_topology(data) if isinstance(data, dict) else data

    @model_validator(mode="after")
    def _consistent(self):
        names = self.participant_names()
        folded = [n.casefold() for n in names]
        dupes = sorted({n for n, f in zip(names, folded) if folded.count(f) > 1})
        if dupes:  # ignoring case: an export's files per participant would collide on macOS and Windows
            raise ValueError(f"participant names must be unique, ignoring case; repeated: {', '.join(dupes)}")
        if not any(sc.role == "estimated" for sc in self.spacecraft):
            raise ValueError("no spacecraft to estimate: give at least one spacecraft with role: estimated")
        check_repeated_links(self)
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
            check_second_receiver(self, i, link, known)
            if link.receiver in known and link.transponder in known and link.second_receiver is None:
                raise ValueError(f"links[{i}] joins two known participants ({link.receiver!r}, {link.transponder!r}): "
                                 "it carries no information on any estimated state")
            receiver = self.participant(link.receiver)
            for observable in link.observables:
                check_observable(self, i, link, observable, receiver)
        check_station_priority(self)
        check_estimator(self)
        self._check_manoeuvres()
        check_batch_section(self)
        check_smoother(self)
        check_initial_batch(self)
        check_clock_sync(self)
        check_dynamics(self)
        check_model_error(self)
        check_estimated_parameters(self)
        check_empirical_acceleration(self)
        check_ric_process_noise(self)
        check_dead_process_noise(self)
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

    def dynamics_descriptor(self) -> Dynamics:
        """The chosen dynamics model's descriptor: what it is and supports (dynamics.registry)."""
        return DYNAMICS[self.dynamics]

    def estimator_descriptor(self) -> Estimator:
        """The chosen estimator's descriptor: what it carries and supports (estimation.estimator)."""
        return get_estimator(self.estimator)

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

    def spacecraft_names(self) -> list[str]:
        """The estimated spacecraft, in scenario order (the filter's spacecraft blocks)."""
        return [sc.name for sc in self.spacecraft if sc.role == "estimated"]

    def participant_names(self) -> list[str]:
        return [sc.name for sc in self.spacecraft] + [st.name for st in self.ground_stations]

    def participant(self, name: str):
        return next(p for p in [*self.spacecraft, *self.ground_stations] if p.name == name)

