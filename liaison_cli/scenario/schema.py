"""Scenario schema: YAML (safe_load only) -> validated, frozen configuration.

Every problem is reported as one line naming the file, the key, the bad value and what is allowed.
"""

import copy
import re
from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from liaison_cli.dynamics.clock_presets import CLOCK_PRESETS, clock_preset_names
from liaison_cli.dynamics.constants import MOON_RADIUS_KM, SECONDS_PER_DAY, WGS84_EQUATORIAL_RADIUS_KM
from liaison_cli.errors import ScenarioError
from liaison_cli.estimation.estimators import estimator_names
from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.orbits.catalog import catalog_names
from liaison_cli.orbits.departure import MAX_TIME_FROM_PERIAPSIS_S
from liaison_cli.orbits.family_ranges import member_range
from liaison_cli.orbits.families import FAMILIES, family_names
from liaison_cli.radio.carrier import TURNAROUND_S_BAND
from liaison_cli.radio.link_budget import LinkLeg
from liaison_cli.radio.ranging import carrier_sigmas_from_link_budget, pn_chip_rate_bias_m, sigma_from_link_budget
from liaison_cli.scenario.exchange_specs import (
    ORBIT_FILE_KINDS, MeasurementFileSpec, OrbitFileSpec, orbit_file_from_mapping, orbit_json_schema,
    resolve_exchange_files)
from liaison_cli.scenario.schema_rules import (
    all_of, any_of, at_least, each, equals, given, negate, not_given, one_of, schema_rules, together, when)

KEPLERIAN_ORBIT = "lunar_keplerian"
ICRF_STATE_ORBIT = "icrf_state"
DEPARTURE_ORBIT = "departure"
GEOSTATIONARY_ORBIT = "geostationary"
DATED_ONLY_ORBITS = (ICRF_STATE_ORBIT, DEPARTURE_ORBIT, GEOSTATIONARY_ORBIT, *ORBIT_FILE_KINDS)
MAX_RUNS = 1_000_000  # Monte Carlo runs per scenario or grid point: the YAML and --runs share this cap
# Epochs per run (t0 included): a run holds ~1.0-1.5 kB per epoch (measured peak RSS, 2-3 spacecraft: truth,
# measurements, the filter's histories), so 500,000 epochs stay under ~0.75 GB per worker process; 100x the
# largest shipped scenario (4,609 epochs: 10 d at 187.5 s).
MAX_EPOCHS = 500_000
# The smoother's forward record per run (three n x n matrices per epoch), per worker process: 2 GiB leaves
# room for two workers and the rest of a run on a 24 GiB machine.
SMOOTHER_RECORD_MAX_BYTES = 2 * 2**30
MAX_SCENARIO_BYTES = 1 << 20  # a scenario or link file (the shipped ones are < 5 kB)
NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$"
UNIQUE = {"uniqueItems": True}  # the JSON Schema word for a list the loader refuses repeats in


def _allowed_names(schema: dict, what: str) -> None:
    """The JSON Schema's `enum` of a name a validator checks, for editors to offer; imported when the schema is
    generated, as the validators import them when they check (a scenario without them need not)."""
    if what == "mission":
        from liaison_cli.orbits.departure_missions import departure_mission_names as names
    else:
        from liaison_cli.dynamics.dsn_sites import dsn_site_names as names
    schema["enum"] = [*names(), None]


class StrictModel(BaseModel):
    # allow_inf_nan=False: every number in a scenario must be finite (.inf / .nan are refused, one line).
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _reject_unknown_keys(cls, data):
        if isinstance(data, dict):
            allowed = set(cls.model_fields)
            unknown = sorted(str(k) for k in data if k not in allowed)
            if unknown:
                raise ValueError(
                    f"unknown key {unknown[0]!r}; allowed keys here: {', '.join(sorted(allowed))}"
                )
        return data


class KeplerianElements(StrictModel):
    """Moon-centred elements in inertial axes aligned with the rotating frame at t0."""

    a_km: float = Field(gt=MOON_RADIUS_KM, description="semi-major axis, above the lunar radius (km)")
    e: float = Field(ge=0.0, lt=1.0, description="eccentricity; the perilune a_km (1 - e) must clear the lunar "
                     "radius (dimensionless)")
    i_deg: float = Field(ge=0.0, le=180.0, description="inclination (deg)")
    raan_deg: float = Field(0.0, description="right ascension of the ascending node (deg)")
    argp_deg: float = Field(0.0, description="argument of perilune (deg)")
    ta_deg: float = Field(0.0, description="true anomaly at t0 (deg)")

    @model_validator(mode="after")
    def _perilune_above_surface(self):
        if self.a_km * (1.0 - self.e) <= MOON_RADIUS_KM:
            raise ValueError(
                f"perilune a_km*(1-e) = {self.a_km * (1 - self.e):.1f} km is inside the Moon "
                f"(radius {MOON_RADIUS_KM} km)"
            )
        return self


class ClockSpec(StrictModel):
    """A participant's clock: the two-state phase / frequency model (dynamics.clock, 002 Eq. 13-16) with its
    diffusion coefficients (given, or from a named `preset` of dynamics.clock_presets; a given value
    overrides the preset's), deterministic drifts mu1 (s/s) and mu2 (aging, 1/s), and the a-priori spread
    of its initial offset and frequency (the truth draws from it, the filter starts at zero with that
    covariance)."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        any_of(given("preset"), all_of(given("sigma1_s_per_sqrt_s"), given("sigma2_per_sqrt_s")))))

    preset: str | None = Field(None, description="a named oscillator: " + ", ".join(clock_preset_names()),
                               json_schema_extra={"enum": [*clock_preset_names(), None]})
    sigma1_s_per_sqrt_s: float | None = Field(None, gt=0, description="white-frequency diffusion (phase random "
                                              "walk); default the preset's (s/sqrt s)")
    sigma2_per_sqrt_s: float | None = Field(None, ge=0, description="random-walk-frequency diffusion; default the "
                                            "preset's (1/sqrt s)")
    mu1: float = Field(0.0, description="deterministic fractional frequency offset added to the truth (s/s)")
    mu2_per_s: float | None = Field(None, description="deterministic aging; default the preset's, else 0 (1/s)")
    initial_offset_sigma_s: float = Field(gt=0, description="a-priori 1-sigma of the initial clock offset (s)")
    initial_frequency_sigma: float = Field(gt=0, description="a-priori 1-sigma of the initial fractional frequency "
                                           "offset (s/s)")

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, value):
        if value is not None and value not in CLOCK_PRESETS:
            raise ValueError(f"unknown clock preset {value!r}; allowed: {', '.join(clock_preset_names())}")
        return value

    @model_validator(mode="after")
    def _diffusions_given(self):
        if self.preset is None and (self.sigma1_s_per_sqrt_s is None or self.sigma2_per_sqrt_s is None):
            raise ValueError("give a 'preset' (" + ", ".join(clock_preset_names()) + ") or both "
                             "'sigma1_s_per_sqrt_s' and 'sigma2_per_sqrt_s'")
        return self

    @property
    def sigma1(self) -> float:
        return self.sigma1_s_per_sqrt_s if self.sigma1_s_per_sqrt_s is not None else \
            CLOCK_PRESETS[self.preset].sigma1_s_per_sqrt_s

    @property
    def sigma2(self) -> float:
        return self.sigma2_per_sqrt_s if self.sigma2_per_sqrt_s is not None else \
            CLOCK_PRESETS[self.preset].sigma2_per_sqrt_s

    @property
    def mu2(self) -> float:
        if self.mu2_per_s is not None:
            return self.mu2_per_s
        return CLOCK_PRESETS[self.preset].mu2_per_s if self.preset is not None else 0.0


_TARGETS = ("c3_km2_s2", "dla_deg", "rla_deg")


class DepartureSpec(StrictModel):
    """A hyperbolic Earth departure (orbit: departure, dynamics: ephemeris): one of 003's missions, whose
    launch targets are derived on DE421 (orbits.departure_missions), or C3 / DLA / RLA given directly."""

    model_config = ConfigDict(json_schema_extra=schema_rules(when(
        given("mission"), all_of(*map(not_given, _TARGETS)), all_of(*map(given, _TARGETS)))))

    mission: str | None = Field(None, description="one of 003's missions, whose C3, DLA, RLA, parking altitude and "
                                "injection time are derived on DE421 (instead of c3_km2_s2, dla_deg, rla_deg, "
                                "periapsis_altitude_km and time_from_periapsis_s)",
                                json_schema_extra=lambda schema: _allowed_names(schema, "mission"))
    c3_km2_s2: float | None = Field(None, description="launch energy C3, > 0 (km^2/s^2)",
                                    json_schema_extra={"exclusiveMinimum": 0})
    dla_deg: float | None = Field(None, ge=-90.0, le=90.0, description="declination of the outgoing asymptote, "
                                  "ICRF (deg)")
    rla_deg: float | None = Field(None, ge=-360.0, le=360.0, description="right ascension of the outgoing "
                                  "asymptote, ICRF (deg)")
    periapsis_altitude_km: float = Field(185.0, gt=0, description="parking-orbit altitude above the WGS84 equatorial "
                                         "radius, injection at periapsis; without a mission (km)")
    time_from_periapsis_s: float = Field(0.0, ge=0, le=MAX_TIME_FROM_PERIAPSIS_S, description="time since "
                                         "periapsis at the scenario epoch, without a mission; the two-body "
                                         "hyperbola holds for 3 h after periapsis (s)")
    parking_inclination_deg: float | None = Field(None, gt=0, lt=180, description="parking-orbit inclination, at "
                                                  "least |DLA|; default max(28.5, |DLA|) (deg)")
    branch: Literal[1, -1] = Field(1, description="which of the two parking planes of that inclination (1 or -1)")

    @field_validator("mission")
    @classmethod
    def _known_mission(cls, value):
        from liaison_cli.orbits.departure_missions import departure_mission_names

        if value is not None and value not in departure_mission_names():
            raise ValueError(f"unknown mission {value!r}; allowed: {', '.join(departure_mission_names())}")
        return value

    @field_validator("c3_km2_s2")
    @classmethod
    def _hyperbolic(cls, value):
        if value is not None and value <= 0:
            raise ValueError(f"C3 = {value:g} km^2/s^2 is no departure: a hyperbola needs C3 > 0")
        return value

    @model_validator(mode="after")
    def _mission_or_targets(self):
        targets = [self.c3_km2_s2, self.dla_deg, self.rla_deg]
        if self.mission is not None and any(t is not None for t in targets):
            raise ValueError(f"mission {self.mission!r} derives c3_km2_s2 / dla_deg / rla_deg; remove them")
        if self.mission is None and any(t is None for t in targets):
            raise ValueError("give a mission, or all of c3_km2_s2, dla_deg and rla_deg")
        if (self.parking_inclination_deg is not None and self.dla_deg is not None
                and min(self.parking_inclination_deg, 180.0 - self.parking_inclination_deg) < abs(self.dla_deg)):
            raise ValueError(f"parking_inclination_deg = {self.parking_inclination_deg:g} cannot hold an asymptote at "
                             f"dla_deg = {self.dla_deg:g} (needs an inclination of at least |DLA|)")
        return self


class ManoeuvreSpec(StrictModel):
    """An impulsive, deterministic manoeuvre (004's low-energy transfer): the truth applies delta_v_m_s
    (ICRF axes in dated scenarios, rotating axes in the CRTBP) just after the measurement epoch nearest
    epoch_days; the filter estimates it as a Delta-v block starting apriori_sigma_m_s (per axis) off."""

    epoch_days: float = Field(gt=0, description="time after t0, rounded to the nearest measurement epoch (days)")
    delta_v_m_s: list[float] = Field(min_length=3, max_length=3, description="the true impulse x, y, z: ICRF axes "
                                     "in dated scenarios, rotating axes in the CRTBP (m/s)")
    apriori_sigma_m_s: float = Field(gt=0, description="the filter's a-priori 1-sigma of each component (m/s)")


class SpacecraftSpec(StrictModel):
    """A spacecraft: its orbit (where it starts and how it flies) and what the filter knows of it."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        together(equals("orbit", KEPLERIAN_ORBIT), "elements"),
        together(equals("orbit", ICRF_STATE_ORBIT), "state_km"),
        together(equals("orbit", DEPARTURE_ORBIT), "departure"),
        together(equals("orbit", GEOSTATIONARY_ORBIT), "longitude_deg"),
        when(equals("orbit", GEOSTATIONARY_ORBIT), equals("role", "known")),
        when(equals("orbit", *family_names()), one_of(given("period_days"), given("amplitude_km")),
             all_of(not_given("period_days"), not_given("amplitude_km"))),
        when(equals("orbit", KEPLERIAN_ORBIT, *DATED_ONLY_ORBITS), {"properties": {"phase": {"const": 0}}}),
        when(equals("role", "known"), all_of(not_given("clock"), not_given("manoeuvre")))))

    name: str = Field(pattern=NAME_PATTERN, description="unique among spacecraft and ground stations; letters, "
                      "digits, '_', '.', '-'")
    role: Literal["estimated", "known"] = Field(
        "estimated", description="estimated by the filter, or known (its true trajectory is given to the filter)")
    orbit: str = Field(description="a catalog orbit; an orbit family (with period_days or amplitude_km); "
                       f"{KEPLERIAN_ORBIT} (with elements); with dynamics: ephemeris also {ICRF_STATE_ORBIT} "
                       f"(with state_km), {DEPARTURE_ORBIT} (with departure), {GEOSTATIONARY_ORBIT} (with "
                       "longitude_deg), {oem: FILE} or {opm: FILE}",
                       json_schema_extra=lambda schema: orbit_json_schema(schema, [
                           *catalog_names(), KEPLERIAN_ORBIT, *family_names(), *DATED_ONLY_ORBITS]))
    elements: KeplerianElements | None = Field(None, description=f"orbit: {KEPLERIAN_ORBIT}: its elements")
    period_days: float | None = Field(None, gt=0, description="orbit: <family>: the member of this period (days)")
    amplitude_km: float | None = Field(None, gt=0, description="orbit: <family>: the member of this amplitude, Az "
                                       "(spatial families) or Ay (planar) (km)")
    antenna_baseline_m: float | None = Field(None, gt=0, description="interferometer baseline of the receiver, "
                                             "needed to measure LOS angles (m)")
    process_noise_accel_m_s2: float | None = Field(
        None, ge=0, description="this spacecraft's SNC white acceleration sigma_a; default "
        "filter.process_noise_accel_m_s2 (m/s^2)"
    )
    state_km: list[float] | None = Field(None, description=f"orbit: {ICRF_STATE_ORBIT}: geocentric ICRF state at "
                                         "the epoch x, y, z, vx, vy, vz (km, km/s)",
                                         json_schema_extra={"minItems": 6, "maxItems": 6})
    clock: ClockSpec | None = Field(None, description="an onboard clock (estimated by the EKF; simulated, and "
                                    "synchronised by a clock fit, with the batch estimator)")
    departure: DepartureSpec | None = Field(None, description=f"orbit: {DEPARTURE_ORBIT}: the hyperbola")
    apriori_sigma_position_m: float | None = Field(
        None, gt=0, description="this spacecraft's filter a-priori 1-sigma per axis and (initial_error.draw: "
        "fixed_sigma) its initial-error 1-sigma; default: filter's and initial_error's (m)")
    apriori_sigma_velocity_m_s: float | None = Field(None, gt=0, description="as apriori_sigma_position_m, for the "
                                                     "velocity (m/s)")
    manoeuvre: ManoeuvreSpec | None = Field(None, description="an impulsive manoeuvre the filter solves for (ekf)")
    phase: float = Field(0.0, ge=0.0, lt=1.0, description="advance a catalog or family orbit by this fraction of "
                         "its period (e.g. 0.5: the second of a pair half a period apart) (periods)")
    longitude_deg: float | None = Field(None, ge=-180.0, le=360.0, description=f"orbit: {GEOSTATIONARY_ORBIT}: the "
                                        "station-kept longitude, east (004: 130 W = -130) (deg)")
    orbit_file: OrbitFileSpec | None = Field(None, description="orbit: {oem: FILE} or {opm: FILE} (dynamics: "
                                             "ephemeris), read into this key (docs/exchange.md)")

    @model_validator(mode="before")
    @classmethod
    def _orbit_from_file(cls, data):
        return orbit_file_from_mapping(data)

    @field_validator("orbit")
    @classmethod
    def _known_orbit(cls, value):
        allowed = [*catalog_names(), KEPLERIAN_ORBIT, *family_names(), *DATED_ONLY_ORBITS]
        if value not in allowed:
            raise ValueError(f"unknown orbit {value!r}; allowed: {', '.join(allowed)}")
        return value

    @model_validator(mode="after")
    def _elements_iff_keplerian(self):
        if self.orbit == KEPLERIAN_ORBIT and self.elements is None:
            raise ValueError(f"orbit {KEPLERIAN_ORBIT!r} needs an 'elements' mapping")
        if self.orbit != KEPLERIAN_ORBIT and self.elements is not None:
            raise ValueError(f"'elements' is only allowed with orbit {KEPLERIAN_ORBIT!r}")
        if self.orbit in FAMILIES and (self.period_days is None) == (self.amplitude_km is None):
            raise ValueError(f"orbit family {self.orbit!r} needs exactly one of 'period_days' or 'amplitude_km'")
        if self.orbit not in FAMILIES and (self.period_days is not None or self.amplitude_km is not None):
            raise ValueError(
                f"'period_days' / 'amplitude_km' are only allowed with an orbit family ({', '.join(family_names())})")
        if (self.orbit == ICRF_STATE_ORBIT) != (self.state_km is not None):
            raise ValueError(f"orbit {ICRF_STATE_ORBIT!r} and 'state_km' (6 numbers) go together")
        if (self.orbit == DEPARTURE_ORBIT) != (self.departure is not None):
            raise ValueError(f"orbit {DEPARTURE_ORBIT!r} and a 'departure' section go together")
        if (self.orbit == GEOSTATIONARY_ORBIT) != (self.longitude_deg is not None):
            raise ValueError(f"orbit {GEOSTATIONARY_ORBIT!r} and 'longitude_deg' go together")
        if (self.orbit in ORBIT_FILE_KINDS) != (self.orbit_file is not None):
            raise ValueError("orbit: {oem: FILE} or {opm: FILE} is given as a mapping with the file")
        if self.orbit == "oem" and self.manoeuvre is not None:
            raise ValueError("an OEM truth already holds its manoeuvres: remove 'manoeuvre' or use orbit: {opm: FILE}")
        if self.manoeuvre is not None and self.role != "estimated":
            raise ValueError("a manoeuvre is solved for by the filter: give it to an estimated spacecraft")
        if self.orbit == GEOSTATIONARY_ORBIT and self.role != "known":
            raise ValueError(f"orbit {GEOSTATIONARY_ORBIT!r} is station-kept, not flown by the filter's dynamics: "
                             "give it role: known")
        if self.phase and (self.orbit == KEPLERIAN_ORBIT or self.orbit in DATED_ONLY_ORBITS):
            raise ValueError(f"'phase' advances a periodic orbit (catalog or family), not orbit {self.orbit!r}")
        if self.state_km is not None and len(self.state_km) != 6:
            raise ValueError(f"'state_km' needs 6 numbers (x, y, z km, vx, vy, vz km/s), got {len(self.state_km)}")
        if self.state_km is not None:
            radius_km = sum(x * x for x in self.state_km[:3]) ** 0.5
            if radius_km <= WGS84_EQUATORIAL_RADIUS_KM:
                raise ValueError(f"'state_km' puts the spacecraft {radius_km:.1f} km from the Earth's centre, inside "
                                 f"the Earth; allowed: a geocentric position above {WGS84_EQUATORIAL_RADIUS_KM} km")
        if self.role == "known" and self.clock is not None:
            raise ValueError("a known spacecraft's clock is not estimated; remove 'clock' or make it role: estimated")
        return self


class GroundStationSpec(StrictModel):
    """A station on the rotating Earth (dynamics.ground_station): WGS84 geodetic coordinates, the longitude east
    of the Earth-Moon line at t0 in the CRTBP, the true longitude with dynamics: ephemeris; it sees spacecraft
    above its elevation mask. Give either `site` or latitude_deg and longitude_deg."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        any_of(given("site"), all_of(given("latitude_deg"), given("longitude_deg"))),
        optional=("latitude_deg", "longitude_deg")))

    name: str = Field(pattern=NAME_PATTERN, description="unique among spacecraft and ground stations; letters, "
                      "digits, '_', '.', '-'")
    site: str | None = Field(None, description="a named site (dynamics: ephemeris), a DSN 70 m antenna or a VLBA "
                             "dish: its coordinates instead of latitude_deg / longitude_deg / altitude_m",
                             json_schema_extra=lambda schema: _allowed_names(schema, "site"))
    latitude_deg: float = Field(ge=-90.0, le=90.0, description="geodetic latitude, WGS84 (deg)")
    longitude_deg: float = Field(ge=-180.0, le=360.0, description="longitude east: of the Earth-Moon line at t0 in "
                                 "the CRTBP, true with dynamics: ephemeris (deg)")
    altitude_m: float = Field(0.0, ge=-500.0, le=9000.0, description="height above the WGS84 ellipsoid (m)")
    elevation_mask_deg: float = Field(10.0, ge=0.0, lt=90.0, description="the station measures spacecraft above "
                                      "this elevation (deg)")

    @model_validator(mode="before")
    @classmethod
    def _site_coordinates(cls, data):
        if not isinstance(data, dict) or data.get("site") is None:
            return data
        from liaison_cli.dynamics.dsn_sites import dsn_site_geodetic, dsn_site_names

        site = data["site"]
        if site not in dsn_site_names():
            raise ValueError(f"unknown site {site!r}; allowed: {', '.join(dsn_site_names())}")
        coordinates = dict(zip(("latitude_deg", "longitude_deg", "altitude_m"), dsn_site_geodetic(site)))
        # a validated scenario written back (model_dump) carries the site's own coordinates: those pass
        clash = [k for k, v in coordinates.items() if k in data and data[k] != v]
        if clash:
            raise ValueError(f"site {site!r} gives the coordinates; remove {', '.join(clash)}")
        return {**data, **coordinates}


ObservableName = Literal[tuple(OBSERVABLES)]
_DIFFERENCES = [name for name, spec in OBSERVABLES.items() if spec.needs_second_receiver]  # tdoa, fdoa


class LinkNoiseSpec(StrictModel):
    """This link's own sigmas, overriding the scenario's noise section for its channels (e.g. 003: DSN range
    10 m and range-rate 0.5 mm/s beside crosslinks at 1 m and 1 mm/s)."""

    sigma_m: float | None = Field(None, gt=0, description="1-sigma of range-like channels (pseudoranges: per "
                                  "one-way) (m)")
    range_rate_sigma_m_s: float | None = Field(None, gt=0, description="1-sigma of range-rate channels (m/s)")
    los_path_sigma_m: float | None = Field(None, gt=0, description="1-sigma of the LOS path difference across the "
                                           "receiver's baseline (m)")

    def applied_to(self, noise):
        """The scenario's noise spec with this link's values in force."""
        update = self.model_dump(exclude_none=True)
        if "sigma_m" in update:
            update["ranging_method"] = None
        if "range_rate_sigma_m_s" in update or "los_path_sigma_m" in update:
            update["carrier"] = None
        return noise.model_copy(update=update)


class LinkSpec(StrictModel):
    """A link between two participants: the receiver (mothercraft, or ground station) measures through the
    transponder (for one-way observables such as pseudorange: the transmitter). `occultation: true` blanks
    epochs at which the Earth or the Moon blocks the line of sight; links to a ground station always obey
    the station's elevation mask."""

    model_config = ConfigDict(json_schema_extra=schema_rules(when(
        given("second_receiver"), {"required": ["observables"], **each("observables", {"enum": _DIFFERENCES})},
        {"properties": {"observables": negate({"contains": {"enum": _DIFFERENCES}})}})))

    receiver: str = Field(description="the measuring end: a spacecraft or ground station name")
    transponder: str = Field(description="the other end (the transmitter of one-way observables): a spacecraft "
                             "or ground station name")
    second_receiver: str | None = Field(None, description="the other receiver of a difference of arrival (tdoa, "
                                        "fdoa): value = second minus first")
    observables: list[ObservableName] = Field(default_factory=lambda: ["range"], min_length=1,
                                              description="what the link measures, each at most once",
                                              json_schema_extra=UNIQUE)
    occultation: bool = Field(False, description="blank the epochs at which the Earth or the Moon blocks the line "
                              "of sight")
    noise: LinkNoiseSpec | None = Field(None, description="this link's sigmas (default: the noise section's)")

    @field_validator("observables")
    @classmethod
    def _no_repeats(cls, value):
        if len(set(value)) != len(value):
            raise ValueError(f"repeated observable in {value}")
        return value


class TopologySpec(StrictModel):
    """`star`: the hub (mothercraft) receives from every other spacecraft; `mesh`: every pair is linked,
    the spacecraft listed first receiving. Expanded into `links` when the scenario is read."""

    model_config = ConfigDict(json_schema_extra=schema_rules(when(equals("kind", "star"), given("hub"),
                                                                  not_given("hub"))))

    kind: Literal["star", "mesh"] = Field(description="star: the hub receives from every other spacecraft; mesh: "
                                          "every pair is linked")
    hub: str | None = Field(None, description="star: the receiving spacecraft (mothercraft)")
    observables: list[ObservableName] = Field(default_factory=lambda: ["range"], min_length=1,
                                              description="what every link measures, each at most once",
                                              json_schema_extra=UNIQUE)


def _expand_topology(data: dict) -> dict:
    """Before validation: turn `topology` into the explicit link list (kept beside it for provenance)."""
    topology = data.get("topology")
    if not isinstance(topology, dict) or not isinstance(data.get("spacecraft"), list):
        return data
    names = [sc.get("name") for sc in data["spacecraft"] if isinstance(sc, dict)]
    kind, hub = topology.get("kind"), topology.get("hub")
    if kind == "star":
        if hub is None:
            raise ValueError(f"topology star needs a 'hub' (the mothercraft); spacecraft: {', '.join(map(str, names))}")
        if hub not in names:
            raise ValueError(f"topology hub {hub!r} is not a spacecraft; defined: {', '.join(map(str, names))}")
        links = [{"receiver": hub, "transponder": name} for name in names if name != hub]
        observables = topology.get("observables")
    elif kind == "mesh":
        if hub is not None:
            raise ValueError("topology mesh takes no 'hub' (every pair is linked)")
        links = [{"receiver": a, "transponder": b} for i, a in enumerate(names) for b in names[i + 1 :]]
        observables = topology.get("observables")
    else:
        raise ValueError(f"topology kind {kind!r} is not allowed; allowed: star, mesh")
    given = data.get("links")
    if given is not None:
        normalised = [{"receiver": li.get("receiver"), "transponder": li.get("transponder")}
                      for li in given if isinstance(li, dict)]
        if normalised != links:
            raise ValueError("give either 'links' or 'topology', not both")
        return data
    if observables is not None:
        links = [{**link, "observables": observables} for link in links]
    return {**data, "links": links}


class LinkLegSpec(StrictModel):
    """One direction of a crosslink (000 Table 2): EIRP, free-space loss and G/T give C/N0 and Es/N0."""

    distance_km: float = Field(gt=0, description="transmitter-receiver distance (km)")
    frequency_mhz: float = Field(gt=0, description="carrier frequency (MHz)")
    tx_power_dbw: float = Field(description="transmitter power (dBW)")
    tx_losses_db: float = Field(ge=0, description="transmitter losses (dB)")
    tx_antenna_gain_dbi: float = Field(description="transmit antenna gain (dBi)")
    data_rate_bps: float = Field(gt=0, description="information bit rate (bit/s)")
    rx_losses_db: float = Field(ge=0, description="receiver losses (dB)")
    rx_g_over_t_db_k: float = Field(description="receiver figure of merit G/T (dB/K)")
    margin_db: float = Field(0.0, ge=0, description="design margin held back from Es/N0 (dB)")
    code_rate: float = Field(1.0, gt=0, le=1, description="information bits per channel symbol, 1 = uncoded "
                             "(dimensionless)")

    def leg(self) -> LinkLeg:
        return LinkLeg(**self.model_dump())


class LinkBudgetSpec(StrictModel):
    """Both legs of a two-way transponder link."""

    uplink: LinkLegSpec = Field(description="receiver to transponder")
    downlink: LinkLegSpec = Field(description="transponder back to the receiver")


RANGING_METHODS = ("time_derived", "telemetry", "pn", "tone")
RangingMethod = Literal["time_derived", "telemetry", "pn", "tone"]
CLOCK_KEYS = ("ranging_clock_hz", "loop_bandwidth_hz", "ranging_power_fraction_db")


class CarrierSpec(StrictModel):
    """Carrier-phase observables of a two-way coherent link, from the link budget (001 Eq. 5, 9)."""

    power_fraction_db: float = Field(le=0, description="residual carrier share of each leg's received power (dB)")
    loop_bandwidth_hz: float = Field(gt=0, description="one-sided carrier PLL noise bandwidth at both ends (Hz)")
    doppler_count_s: float = Field(gt=0, description="Doppler count (integration) time (s)")
    turnaround_ratio: float = Field(TURNAROUND_S_BAND, gt=0, description="transponder downlink/uplink frequency "
                                    "ratio; default S-band 240/221 (dimensionless)")

    def sigmas(self, link_budget: "LinkBudgetSpec") -> dict:
        return carrier_sigmas_from_link_budget(
            link_budget.uplink.leg(), link_budget.downlink.leg(), self.power_fraction_db,
            self.loop_bandwidth_hz, self.doppler_count_s, self.turnaround_ratio)


class NoiseSpec(StrictModel):
    """Range sigma: `sigma_m` directly, or `ranging_method` + `link_budget` (000 Eq. 1-4, 001 Eq. 62-63).
    Range-rate and LOS sigmas: directly, or from the link budget's carrier (`carrier`, 001 Eq. 5 and 9)."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        one_of(given("sigma_m"), given("ranging_method")),
        when(given("ranging_method"), given("link_budget")),
        when(given("carrier"), all_of(given("link_budget"), not_given("range_rate_sigma_m_s"),
                                      not_given("los_path_sigma_m"))),
        when(given("link_budget"), any_of(given("ranging_method"), given("carrier"))),
        when(equals("ranging_method", "telemetry", "pn", "tone"), all_of(*map(given, CLOCK_KEYS))),
        when(given("pn_chip_rate_offset_hz"), equals("ranging_method", "pn"))))

    sigma_m: float | None = Field(None, gt=0, description="1-sigma of range-like channels (m)")
    ranging_method: RangingMethod | None = Field(None, description="derive the range sigma from link_budget by "
                                                 "this method instead of giving sigma_m")
    link_budget: LinkBudgetSpec | None = Field(None, description="for ranging_method and carrier")
    correlator_integration_s: float = Field(0.3, gt=0, description="correlator integration time (s)")
    ranging_clock_hz: float | None = Field(None, gt=0, description="PN / telemetry ranging clock, or the major "
                                           "tone (Hz)")
    loop_bandwidth_hz: float | None = Field(None, gt=0, description="one-sided ranging clock / tone tracking loop "
                                            "bandwidth (Hz)")
    ranging_power_fraction_db: float | None = Field(None, le=0, description="share of the received uplink power in "
                                                    "the ranging clock or tone (dB)")
    carrier: CarrierSpec | None = Field(None, description="derive the range-rate and LOS sigmas from link_budget")
    bias_m: float = Field(0.0, description="constant bias added to the range-like channels of every link in the "
                          "truth (m)")
    bias_sigma_m: float = Field(0.0, ge=0, description="per run and link, a random bias of this 1-sigma is added "
                                "(m)")
    bias_distribution: Literal["normal", "uniform"] = Field(
        "normal", description="the per-run bias's law: normal, or uniform over +-sqrt(3) bias_sigma_m (003)")
    pn_chip_rate_offset_hz: float | None = Field(
        None, description="PN ranging: received minus local chip rate; adds the constant bias of 000 Eq. 2 (Hz)")
    range_rate_sigma_m_s: float | None = Field(None, gt=0, description="1-sigma of range-rate channels (m/s)")
    los_path_sigma_m: float | None = Field(
        None, gt=0, description="path-difference error across the receiver's baseline (LOS, 001 Eq. 8) (m)")
    tdoa_sigma_ns: float | None = Field(None, gt=0, description="1-sigma of TDoA channels (004 Table 3: 20 ns) (ns)")
    fdoa_sigma_hz: float | None = Field(None, gt=0, description="1-sigma of FDoA channels (004 Table 3: 0.04 Hz) "
                                        "(Hz)")
    carrier_frequency_hz: float | None = Field(None, gt=0, description="the transmitter's carrier, for FDoA (Hz)")

    @model_validator(mode="after")
    def _one_source_of_sigma(self):
        if self.sigma_m is None and self.ranging_method is None:
            raise ValueError("give 'sigma_m' or both 'ranging_method' and 'link_budget'")
        if self.sigma_m is not None and self.ranging_method is not None:
            raise ValueError("give either 'sigma_m' or 'ranging_method' + 'link_budget', not both")
        if self.ranging_method is not None and self.link_budget is None:
            raise ValueError("'ranging_method' and 'link_budget' go together")
        if self.carrier is not None and self.link_budget is None:
            raise ValueError("'carrier' derives its sigmas from the link budget: give 'link_budget'")
        if self.link_budget is not None and self.ranging_method is None and self.carrier is None:
            raise ValueError("'link_budget' is used by 'ranging_method' or 'carrier'; give one of them")
        if self.ranging_method in ("telemetry", "pn", "tone"):
            missing = [k for k in CLOCK_KEYS if getattr(self, k) is None]
            if missing:
                raise ValueError(f"ranging_method {self.ranging_method!r} needs {', '.join(missing)}")
        if self.pn_chip_rate_offset_hz is not None and self.ranging_method != "pn":
            raise ValueError("'pn_chip_rate_offset_hz' applies to ranging_method 'pn' only")
        if self.carrier is not None:
            for key in ("range_rate_sigma_m_s", "los_path_sigma_m"):
                if getattr(self, key) is not None:
                    raise ValueError(f"give either '{key}' or 'carrier' (which derives it), not both")
        return self

    def resolved_sigma_m(self) -> float:
        if self.sigma_m is not None:
            return self.sigma_m
        return sigma_from_link_budget(
            self.ranging_method,
            self.link_budget.uplink.leg(),
            self.link_budget.downlink.leg(),
            self.correlator_integration_s,
            self.ranging_clock_hz,
            self.loop_bandwidth_hz,
            self.ranging_power_fraction_db,
        )

    def resolved_bias_m(self) -> float:
        """The constant range bias: `bias_m`, plus the PN chip-rate-mismatch bias (000 Eq. 2) if given."""
        if self.pn_chip_rate_offset_hz is None:
            return self.bias_m
        return self.bias_m + pn_chip_rate_bias_m(self.ranging_clock_hz, self.pn_chip_rate_offset_hz,
                                                 self.correlator_integration_s)

    def resolved_range_rate_sigma_m_s(self) -> float | None:
        if self.carrier is not None:
            return self.carrier.sigmas(self.link_budget)["range_rate_sigma_m_s"]
        return self.range_rate_sigma_m_s

    def resolved_los_path_sigma_m(self) -> float | None:
        if self.carrier is not None:
            return self.carrier.sigmas(self.link_budget)["los_path_sigma_m"]
        return self.los_path_sigma_m


class DualOneWayReceiverSpec(StrictModel):
    """A dual one-way ranging receiver (002 §2, Eq. 8-12): code (DLL) and carrier (PLL) tracking."""

    carrier_frequency_hz: float = Field(gt=0, description="carrier frequency (Hz)")
    c_n0_db_hz: float = Field(gt=0, le=100, description="received carrier-to-noise density C/N0 (dB-Hz)")
    code_loop_bandwidth_hz: float = Field(gt=0, description="B_n of the DLL (Hz)")
    code_integration_s: float = Field(gt=0, description="predetection integration of the DLL (s)")
    front_end_bandwidth_hz: float = Field(gt=0, description="two-sided front-end bandwidth B_fe (Hz)")
    chip_rate_hz: float = Field(gt=0, description="spreading-code rate R_c (chip/s)")
    correlator_spacing_s: float = Field(gt=0, description="early-to-late spacing D (s)")
    doppler_bandwidth_hz: float = Field(gt=0, description="B_d of the PLL (Hz)")
    carrier_integration_s: float = Field(gt=0, description="coherent integration of the PLL (s)")

    @model_validator(mode="after")
    def _spacing_below_two_chips(self):
        if self.correlator_spacing_s * self.chip_rate_hz >= 2.0:
            raise ValueError(f"correlator_spacing_s = {self.correlator_spacing_s} is "
                             f"{self.correlator_spacing_s * self.chip_rate_hz:.3g} chips; the DLL model needs < 2 chips")
        return self

    def receiver(self):
        from liaison_cli.radio.dual_one_way import DualOneWayReceiver

        return DualOneWayReceiver(**self.model_dump())


class RangingLinkFile(StrictModel):
    """A crosslink for `liaison budget`: both legs' link budgets plus the ranging parameters, and optionally
    the carrier (Doppler / LOS); or a dual one-way receiver (002), or both. Methods whose parameters are
    missing (telemetry / PN / tone need the ranging clock or tone) are reported as not computable."""

    description: str = ""
    link_budget: LinkBudgetSpec | None = None
    dual_one_way: DualOneWayReceiverSpec | None = None
    correlator_integration_s: float = Field(0.3, gt=0)
    ranging_clock_hz: float | None = Field(None, gt=0)
    loop_bandwidth_hz: float | None = Field(None, gt=0)
    ranging_power_fraction_db: float | None = Field(None, le=0)
    carrier: CarrierSpec | None = None

    @model_validator(mode="after")
    def _something_to_compute(self):
        if self.link_budget is None and self.dual_one_way is None:
            raise ValueError("give 'link_budget' (transponder ranging) or 'dual_one_way' (002 receiver), or both")
        if self.carrier is not None and self.link_budget is None:
            raise ValueError("'carrier' derives its sigmas from the link budget: give 'link_budget'")
        return self

    def sigma_by_method(self) -> dict:
        """{method: sigma_m or None when its parameters are missing}; empty without a link budget."""
        if self.link_budget is None:
            return {}
        clock = tuple(getattr(self, k) for k in CLOCK_KEYS)
        out = {}
        for method in RANGING_METHODS:
            if method != "time_derived" and None in clock:
                out[method] = None
                continue
            out[method] = sigma_from_link_budget(
                method, self.link_budget.uplink.leg(), self.link_budget.downlink.leg(),
                self.correlator_integration_s, *clock,
            )
        return out


class MeasurementSpec(StrictModel):
    """When every link measures, and how the truth is simulated."""

    interval_s: float = Field(gt=0, description="time between measurement epochs, from t0 (s)")
    light_time: bool = Field(True, description="simulate the truth with light time (false: instantaneous)")


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


class FilterSpec(StrictModel):
    """The estimator's settings: a priori, process noise, health checks, the filter's measurement models."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        when(equals("bias", "estimate", "consider"), given("bias_apriori_sigma_m"))))

    initial_sigma_position_m: float = Field(1000.0, gt=0, description="a-priori 1-sigma per position axis (m)")
    initial_sigma_velocity_m_s: float = Field(0.01, gt=0, description="a-priori 1-sigma per velocity axis (m/s)")
    process_noise_accel_m_s2: float = Field(1e-7, ge=0, description="SNC white acceleration sigma_a of every "
                                            "spacecraft (a spacecraft's own key overrides it) (m/s^2)")
    process_noise_model: Literal["continuous_white_acceleration", "velocity_only"] = Field(
        "continuous_white_acceleration", description="how sigma_a becomes Q per step dt: continuous white "
        "acceleration (q = sigma_a^2 dt; Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]] per axis) or (sigma_a dt)^2 on "
        "the velocities only (the form before issue 26)")
    divergence_position_km: float = Field(1e4, gt=0, description="a run whose position error exceeds this is "
                                          "stopped as diverged (km)")
    divergence_nees_factor: float = Field(
        100.0, ge=1, description="a run whose NEES stays above this many times its 99.9 % chi-square quantile "
        "for divergence_window_days is diverged (dimensionless)")
    divergence_window_days: float = Field(1.0, gt=0, description="see divergence_nees_factor (days)")
    rk4_substeps: int = Field(4, ge=1, le=256, description="RK4 steps of the filter's propagation per "
                              "measurement interval (count)")
    range_model: Literal["geometric", "light_time"] = Field(
        "geometric", description="filter's two-way range: geometric (paper Eq. 17) or light-time corrected"
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
    def _bias_needs_apriori(self):
        if self.bias != "ignore" and self.bias_apriori_sigma_m is None:
            raise ValueError(f"bias {self.bias!r} needs 'bias_apriori_sigma_m' (the a-priori 1-sigma, m)")
        return self


ThirdBodyName = Literal["moon", "sun", "mercury", "venus", "mars", "jupiter", "saturn", "uranus", "neptune", "pluto"]


class EphemerisSpec(StrictModel):
    """Dated dynamics (003): the epoch (UTC, ISO 8601) and the SRP cannonball of every spacecraft."""

    epoch_utc: str = Field(description="ISO 8601, UTC (e.g. 2011-11-26T15:52:12.383); a UTC offset "
                           "(2011-11-26T20:52:12+05:00) is converted to UTC")
    cr: float = Field(1.5, gt=0, description="coefficient of reflectivity C_R (003: 1.5) (dimensionless)")
    area_to_mass_m2_kg: float = Field(0.01, ge=0, description="area-to-mass ratio (003: 0.01) (m^2/kg)")
    node_spacing_days: float = Field(1.0, gt=0, description="patch-point spacing of the multiple shooting that "
                                     "corrects catalog and family orbits into the dated model (days)")
    cr_error_sigma: float = Field(0.0, ge=0, lt=1, description="per run, the filter's C_R is the truth's times "
                                  "(1 + N(0, cr_error_sigma)) (003: 0.05) (dimensionless)")
    filter_bodies: list[ThirdBodyName] = Field(
        default_factory=lambda: ["moon", "sun"],
        description="third bodies in the filter's model beside the Earth (the truth has them all; 003: the Moon "
        "and the Sun)", json_schema_extra=UNIQUE)

    @field_validator("filter_bodies")
    @classmethod
    def _no_repeated_bodies(cls, value):
        if len(set(value)) != len(value):
            raise ValueError(f"repeated body in {value}")
        return value

    @field_validator("epoch_utc")
    @classmethod
    def _iso_date(cls, value):
        from datetime import datetime

        try:
            datetime.fromisoformat(value)
        except ValueError:
            raise ValueError("not an ISO 8601 date and time (e.g. 2011-11-26T15:52:12.383)") from None
        return value

    def epoch(self):
        """The epoch as a UTC datetime: without an offset the text is UTC; with one (+05:00, Z) it is converted."""
        from datetime import datetime

        from liaison_cli.dynamics.timescales import as_utc

        return as_utc(datetime.fromisoformat(self.epoch_utc))


class BatchSpec(StrictModel):
    """The batch least-squares estimator (estimator: batch, 002 §3): one solve for the epoch state from the
    measurements of the first `span_days`, predicted `prediction_hours` past the span (002's DRMS window).
    The scenario's epochs end at span + prediction (duration_days must cover them)."""

    model_config = ConfigDict(json_schema_extra=schema_rules(when(at_least("windows", 2), given("renewal_hours"))))

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
        if self.windows > 1 and self.renewal_hours is None:
            raise ValueError(f"windows = {self.windows} needs 'renewal_hours' (the spacing of window starts)")
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
    """`fixed_sigma`: independent normal errors with the sigmas below (the paper's Monte Carlo);
    `from_covariance`: drawn from the filter's own P0 (for NEES consistency checks)."""

    draw: Literal["fixed_sigma", "from_covariance"] = Field("fixed_sigma", description="fixed_sigma: the sigmas "
                                                            "below; from_covariance: the filter's P0")
    sigma_position_m: float = Field(500.0, ge=0, description="fixed_sigma: 1-sigma per position axis (m)")
    sigma_velocity_m_s: float = Field(0.001, ge=0, description="fixed_sigma: 1-sigma per velocity axis (m/s)")


class MonteCarloSpec(StrictModel):
    """How many runs, and the seed every run's random numbers derive from (with the run index)."""

    runs: int = Field(ge=1, le=MAX_RUNS, description="Monte Carlo runs; `liaison run --runs` overrides (count)")
    seed: int = Field(ge=0, description="master seed; a run's numbers depend on (scenario, seed, run index) only "
                      "(integer)")


class Scenario(StrictModel):
    """A Monte Carlo campaign: who flies where, who measures whom, how the filter runs, how many runs."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        any_of(given("links"), given("topology")),
        together(equals("estimator", "batch"), "batch"),
        when(equals("dynamics", "ephemeris"),
             all_of(given("ephemeris"), negate(equals("estimator", "batch")),
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
    dynamics: Literal["crtbp", "ephemeris"] = Field("crtbp", description="crtbp: the Earth-Moon CRTBP, undated; "
                                                    "ephemeris: DE421 point masses + SRP from ephemeris.epoch_utc")
    ephemeris: EphemerisSpec | None = Field(None, description="dynamics: ephemeris: the epoch and SRP")
    estimator: Literal[tuple(estimator_names())] = Field("ekf", description="ekf: the extended Kalman filter; "
                                                         "batch: least squares (with a batch section)")
    batch: BatchSpec | None = Field(None, description="estimator: batch: its span and settings")
    clock_sync: ClockSyncSpec | None = Field(None, description="clock synchronisation by a polynomial fit to "
                                             "dual_one_way_derived clock offsets")
    topology: TopologySpec | None = Field(None, description="star or mesh links, expanded into links when read")
    measurement: MeasurementSpec = Field(description="measurement epochs and the truth's light time")
    noise: NoiseSpec = Field(description="measurement noise and biases of every link (a link's noise overrides)")
    filter: FilterSpec = Field(FilterSpec(), description="the estimator's settings")
    initial_error: InitialErrorSpec = Field(InitialErrorSpec(), description="how each run's initial state error "
                                            "is drawn")
    monte_carlo: MonteCarloSpec = Field(description="runs and seed")
    measurements: MeasurementFileSpec | None = Field(None, description="{tdm: FILE}: the filter's measurements from "
                                                     "a TDM, one run (docs/exchange.md)")

    @model_validator(mode="before")
    @classmethod
    def _topology_to_links(cls, data):
        return _expand_topology(data) if isinstance(data, dict) else data

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
        self._check_manoeuvres()
        self._check_batch()
        self._check_smoother()
        self._check_initial_batch()
        self._check_clock_sync()
        self._check_dynamics()
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
        if self.estimator == "batch":
            raise ValueError("filter.smoother = 'rts' smooths an EKF pass; estimator: batch is already a "
                             "smoothing solution (use one or the other)")
        if self.filter.bias == "consider":
            raise ValueError("filter.smoother = 'rts' with filter.bias = 'consider': not supported (estimate or "
                             "ignore the bias)")
        if self.filter.underweighting > 0:
            raise ValueError(f"filter.smoother = 'rts' with filter.underweighting = {self.filter.underweighting:g}: "
                             "the RTS recursion assumes the optimal gain; allowed: underweighting 0 with the smoother")
        moving = [sc.name for sc in self.spacecraft if sc.manoeuvre is not None]
        if moving:
            raise ValueError(f"filter.smoother = 'rts' with a manoeuvre ({moving[0]!r}): not supported")

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
        if self.estimator != "ekf":
            raise ValueError(f"filter.initial_batch_hours starts an EKF; estimator: {self.estimator} (allowed: ekf)")
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
        if (self.estimator == "batch") != (self.batch is not None):
            raise ValueError(f"key 'estimator' = {self.estimator!r} "
                             f"{'without' if self.batch is None else 'with'} a 'batch' section: estimator: batch "
                             "and a 'batch' section go together (give both or neither)")
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
        for i, link in enumerate(self.links):
            for observable in link.observables:
                spec = OBSERVABLES[observable]
                if spec.needs_receiver_clock or any(
                        spec.channel_clock_coefficients(c) != (0.0, 0.0) and c != spec.clock_offset_channel
                        for c in range(len(spec.channels))):
                    raise ValueError(f"links[{i}] measures {observable!r}, whose value carries clock states: the "
                                     "batch estimator solves for orbits only; use dual_one_way_derived (range + "
                                     "clock offset, synchronised by clock_sync) or the ekf")
        if self.filter.residual_gate_sigma is not None:
            raise ValueError(f"filter.residual_gate_sigma = {self.filter.residual_gate_sigma:g} gates the EKF's "
                             "pre-fit innovations; the batch estimator (estimator: batch) has no residual gate: "
                             "remove the key or use estimator: ekf")

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
            if self.estimator != "ekf":
                raise ValueError(f"spacecraft[{i}].manoeuvre: the ekf solves for manoeuvres (estimator: ekf)")
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

    def _check_dynamics(self):
        if self.dynamics == "crtbp":
            for i, st in enumerate(self.ground_stations):
                if st.site is not None:
                    raise ValueError(f"ground_stations[{i}].site = {st.site!r} needs dynamics: ephemeris (CRTBP "
                                     "stations take a longitude from the Earth-Moon line, not a true one)")
            if self.ephemeris is not None:
                raise ValueError("an 'ephemeris' section needs dynamics: ephemeris")
            for i, sc in enumerate(self.spacecraft):
                if sc.orbit in DATED_ONLY_ORBITS:
                    raise ValueError(f"spacecraft[{i}].orbit = {sc.orbit!r} needs dynamics: ephemeris")
            return
        if self.ephemeris is None:
            raise ValueError("key 'dynamics' = 'ephemeris' needs an 'ephemeris' section with its epoch_utc")
        from liaison_cli.dynamics.ephemeris import de421_span_s
        from liaison_cli.dynamics.timescales import utc_to_tdb_seconds

        try:
            start = utc_to_tdb_seconds(self.ephemeris.epoch())
        except ValueError as exc:
            raise ValueError(f"ephemeris.epoch_utc = {self.ephemeris.epoch_utc!r}: {exc}") from None
        lo, hi = de421_span_s()
        if start < lo or start + self.duration_days * SECONDS_PER_DAY > hi:
            raise ValueError(f"ephemeris.epoch_utc = {self.ephemeris.epoch_utc!r} plus {self.duration_days:g} d is "
                             "outside DE421 (1899-07-29 to 2053-10-09)")
        self._check_earth_orientation()
        if self.estimator != "ekf":
            raise ValueError("dynamics: ephemeris runs the ekf today (estimator: ekf)")
        timed = [o for link in self.links for o in link.observables if not OBSERVABLES[o].light_time_from_states]
        if self.measurement.light_time and timed:
            raise ValueError(f"dynamics: ephemeris takes measurement.light_time: true for tdoa / fdoa only; "
                             f"{timed[0]!r} is instantaneous there (measurement.light_time: false)")
        for i, link in enumerate(self.links):
            unsupported = [o for o in link.observables if OBSERVABLES[o].channels[0].unit not in ("m", "m/s", "s")
                           or OBSERVABLES[o].needs_receiver_clock or OBSERVABLES[o].needs_both_clocks]
            if unsupported:
                raise ValueError(f"links[{i}]: dynamics: ephemeris takes range, range-rate, tdoa and fdoa links today; got "
                                 f"{', '.join(unsupported)}")
        self._check_departures()
        for i, sc in enumerate(self.spacecraft):
            if sc.orbit == KEPLERIAN_ORBIT:
                raise ValueError(f"spacecraft[{i}].orbit = {sc.orbit!r}: dynamics: ephemeris takes a catalog or "
                                 f"family orbit (corrected into the dated model), {', '.join(DATED_ONLY_ORBITS)}")

    def _check_earth_orientation(self):
        """Ground stations and geostationary spacecraft turn with the Earth: their epochs need the IERS table
        (dynamics.iers_eop), which begins on 1973-01-02; later epochs past its end run by a stated rule."""
        turning = self.ground_stations or any(sc.orbit == GEOSTATIONARY_ORBIT for sc in self.spacecraft)
        if not turning or self.ephemeris.epoch().year > 1973:  # reading the table costs 0.25 s: only near its start
            return
        from liaison_cli.dynamics.iers_eop import first_day

        if self.ephemeris.epoch() < first_day():
            raise ValueError(f"ephemeris.epoch_utc = {self.ephemeris.epoch_utc!r} is before the IERS Earth orientation "
                             f"table ({first_day():%Y-%m-%d}), which ground stations and geostationary spacecraft "
                             "need; allowed: an epoch from then on")

    def _check_departures(self):
        from datetime import timedelta

        from liaison_cli.orbits.departure_missions import DEPARTURE_MISSIONS

        for i, sc in enumerate(self.spacecraft):
            if sc.departure is None or sc.departure.mission is None:
                continue
            mission = DEPARTURE_MISSIONS[sc.departure.mission]
            injection = mission.start_utc_datetime() - timedelta(seconds=mission.time_from_periapsis_s())
            if self.ephemeris.epoch() < injection:
                raise ValueError(f"spacecraft[{i}].departure.mission = {sc.departure.mission!r}: the scenario epoch "
                                 f"{self.ephemeris.epoch_utc} is before its injection "
                                 f"({injection.strftime('%Y-%m-%dT%H:%M:%S')} UTC)")
            last = injection + timedelta(seconds=MAX_TIME_FROM_PERIAPSIS_S)
            if self.ephemeris.epoch() > last:
                raise ValueError(f"ephemeris.epoch_utc = {self.ephemeris.epoch_utc!r} is "
                                 f"{(self.ephemeris.epoch() - injection).total_seconds() / 3600:.5g} h after the "
                                 f"injection of spacecraft[{i}].departure.mission = {sc.departure.mission!r}; allowed: "
                                 f"{injection.strftime('%Y-%m-%dT%H:%M:%S')} to {last.strftime('%Y-%m-%dT%H:%M:%S')} "
                                 "UTC (the two-body departure hyperbola holds for 3 h after periapsis)")

    def _check_clock_sync(self):
        if self.clock_sync is None:
            return
        window_s = self.clock_sync.window_hours * 3600.0
        if window_s < 2.0 * self.measurement.interval_s:
            raise ValueError(f"clock_sync.window_hours = {self.clock_sync.window_hours:g} is shorter than two "
                             f"measurement intervals ({self.measurement.interval_s:g} s)")
        if not any(OBSERVABLES[o].clock_offset_channel >= 0 for link in self.links for o in link.observables):
            raise ValueError("clock_sync needs a link that measures clock offsets (observable dual_one_way_derived)")

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


def _format_loc(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _one_line(source: str, error: ValidationError) -> str:
    first = error.errors()[0]
    key = _format_loc(first["loc"])
    message = first["msg"].removeprefix("Value error, ")
    if first["type"] in ("model_type", "model_attributes_type", "dict_type"):
        message = "must be a mapping of keys (key: value lines)"
    if first["type"] == "missing":
        return f"{source}: key '{key}' is missing (required)"
    value = first.get("input")
    shown = "" if isinstance(value, (dict, list)) else f" = {value!r}"
    where = f"key '{key}'{shown}: " if key else ""
    return f"{source}: {where}{message}"


def validate_scenario(data, source: str = "<scenario>", model=Scenario):
    if not isinstance(data, dict):
        raise ScenarioError(f"{source}: the file must be a YAML mapping of keys, got {type(data).__name__}")
    try:
        validated = model.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(_one_line(source, exc)) from None
    if isinstance(validated, Scenario):
        _check_family_periods(validated, source)
    return validated


def _check_family_periods(scenario: Scenario, source: str) -> None:
    """A family member must exist: its period (or amplitude) has to lie in the family's range (recorded
    data: validation never reads or generates families on disk)."""
    for i, sc in enumerate(scenario.spacecraft):
        if sc.orbit not in FAMILIES:
            continue
        key, unit, digits = ("period_days", "days", 3) if sc.period_days is not None else ("amplitude_km", "km", 0)
        value = getattr(sc, key)
        lo, hi = member_range(sc.orbit, key)
        if not lo <= value <= hi:
            raise ScenarioError(
                f"{source}: key 'spacecraft[{i}].{key}' = {value!r}: outside orbit family "
                f"{sc.orbit!r}; valid {lo:.{digits}f} to {hi:.{digits}f} {unit}"
            )


def _read_bounded(path: Path) -> str:
    """The file's text, refused before reading anything that is not a regular file (a FIFO would block,
    /dev/zero never ends, a directory has no text) or is larger than MAX_SCENARIO_BYTES; at most that many
    bytes are read even if the file grows meanwhile."""
    import os
    import stat

    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise ScenarioError(f"{path}: no such scenario file") from None
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read the scenario ({exc.__class__.__name__}: {exc})") from None
    if not stat.S_ISREG(info.st_mode):
        kind = "a directory" if stat.S_ISDIR(info.st_mode) else "not a regular file"
        raise ScenarioError(f"{path}: {kind}; allowed: a regular YAML file")
    if info.st_size > MAX_SCENARIO_BYTES:
        raise ScenarioError(f"{path}: {info.st_size:,} bytes; allowed: a YAML file of at most "
                            f"{MAX_SCENARIO_BYTES:,} bytes (1 MiB)")
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_SCENARIO_BYTES + 1)
        if len(data) > MAX_SCENARIO_BYTES:
            raise ScenarioError(f"{path}: grew past {MAX_SCENARIO_BYTES:,} bytes while being read; allowed: a YAML "
                                "file of at most 1 MiB")
        return data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read the scenario ({exc.__class__.__name__}: {exc})") from None


class _YamlLoader(yaml.SafeLoader):
    """safe_load, with 1e5 and 1.0e5 read as numbers, as YAML 1.2 and editors read them (PyYAML's YAML 1.1
    rule wants a dot and a signed exponent, 1.0e+5, and gave the text '1.0e5', which only pydantic's coercion
    turned into a number: the JSON Schema saw a string where the editor saw a number)."""


_YamlLoader.add_implicit_resolver("tag:yaml.org,2002:float",
                                  re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
                                  list("-+0123456789"))


def read_scenario_text(path) -> tuple[dict, str]:
    path = Path(path)
    text = _read_bounded(path)
    try:
        data = yaml.load(text, Loader=_YamlLoader)  # a SafeLoader: no Python objects from the file
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ScenarioError(f"{path}: malformed YAML{where}: {problem}") from None
    return data, text


def load_scenario(path) -> tuple[Scenario, str]:
    """Read and validate a scenario file. Returns (scenario, original text)."""
    data, text = read_scenario_text(path)
    return validate_scenario(resolve_exchange_files(data, Path(path).parent), str(path)), text


def load_link_file(path) -> RangingLinkFile:
    """Read and validate a `liaison budget` link file."""
    data, _ = read_scenario_text(path)
    return validate_scenario(data, str(path), RangingLinkFile)


LINK_FILE_KEYS = ("link_budget", "dual_one_way")  # top-level keys of a link file, never of a scenario


def check_file(path) -> str:
    """Every check `liaison run` makes of a scenario before it computes (reading, keys, values, the rules
    between them, dates, orbit families' ranges), or `liaison budget` of a link file; nothing is propagated
    or compiled. Returns what the file is ('scenario' or 'link file'); a problem raises ScenarioError."""
    data, _ = read_scenario_text(path)
    if isinstance(data, dict) and "spacecraft" not in data and any(k in data for k in LINK_FILE_KEYS):
        validate_scenario(data, str(path), RangingLinkFile)
        return "link file"
    validate_scenario(data, str(path))
    return "scenario"


def apply_overrides(scenario: Scenario, overrides: dict, source: str = "<override>") -> Scenario:
    """Set dotted-path keys (e.g. {'noise.sigma_m': 300}) and re-validate. A value of None removes the
    key, so its default applies (e.g. {'noise.ranging_method': None} before setting 'noise.sigma_m')."""
    data = copy.deepcopy(scenario.model_dump(exclude_none=True))
    for dotted, value in overrides.items():
        node = data
        parts = [int(p) if p.isdigit() else p for p in dotted.split(".")]
        for part in parts[:-1]:
            try:
                node = node[part]
            except (KeyError, IndexError, TypeError):
                raise ScenarioError(f"{source}: key '{dotted}' does not exist in the scenario") from None
        if isinstance(node, list) and not (isinstance(parts[-1], int) and parts[-1] < len(node)):
            raise ScenarioError(f"{source}: key '{dotted}' does not exist in the scenario")
        if value is None:
            if isinstance(node, dict):
                node.pop(parts[-1], None)
            else:
                raise ScenarioError(f"{source}: key '{dotted}' is a list item and cannot be removed")
        else:
            node[parts[-1]] = value
    return validate_scenario(data, source)

