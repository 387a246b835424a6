"""Scenario participants: spacecraft (orbit, clock, manoeuvre, departure), ground stations, and the dated
(ephemeris) dynamics they fly in."""

from typing import ClassVar, Literal

from pydantic import ConfigDict, Field, field_validator, model_validator

from liaison_cli.dynamics.clock_presets import CLOCK_PRESETS, clock_preset_names
from liaison_cli.dynamics.constants import MOON_RADIUS_KM, WGS84_EQUATORIAL_RADIUS_KM
from liaison_cli.orbits.catalog import catalog_names
from liaison_cli.orbits.departure import MAX_TIME_FROM_PERIAPSIS_S
from liaison_cli.orbits.frozen import NoFrozenOrbit, frozen_elements
from liaison_cli.orbits.families import family_names
from liaison_cli.scenario.exchange_specs import (
    ORBIT_FILE_KINDS, OrbitFileSpec, orbit_file_from_mapping, orbit_json_schema)
from liaison_cli.scenario.schema_rules import (
    Rule, all_of, any_of, check_rules, equals, given, negate, not_given, one_of, schema_rules, together, when)
from liaison_cli.scenario.spec_base import (
    NAME_MAX_LENGTH,
    NAME_PATTERN,
    ONE_PROCESS_NOISE_CONVENTION,
    UNIQUE,
    RicDensities,
    StrictModel,
    allowed_names,
)


KEPLERIAN_ORBIT = "lunar_keplerian"
ICRF_STATE_ORBIT = "icrf_state"
DEPARTURE_ORBIT = "departure"
GEOSTATIONARY_ORBIT = "geostationary"
DATED_ONLY_ORBITS = (ICRF_STATE_ORBIT, DEPARTURE_ORBIT, GEOSTATIONARY_ORBIT, "opm")
# Orbits given whole rather than by a periodic reference: no `phase` to advance. An OEM is read by both dynamics
# (a CRTBP scenario reads liaison's own CRTBP export: scenario.orbit_files); an OPM needs a date.
UNPHASED_ORBITS = (KEPLERIAN_ORBIT, *DATED_ONLY_ORBITS, "oem")


class KeplerianElements(StrictModel):
    """Moon-centred elements in inertial axes aligned with the rotating frame at t0 (in a dated scenario: the Moon's
    principal axes at the epoch, turned as the CRTBP's; scenario.dated.lunar_orbiter_state_km). The orbit's size is a_km or,
    for a low lunar orbit, altitude_km: the perilune's altitude above the mean lunar radius (a circular orbit's
    altitude when e is 0), from which a_km follows. With frozen: true, an elliptical frozen orbit (ELFO): give
    e or i_deg and the other is solved so that the argument of perilune (90 or 270 deg) stands still under the
    Moon's J2 and the Earth's tide (orbits.frozen)."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        one_of(given("a_km"), given("altitude_km")),
        when(equals("frozen", True), one_of(given("e"), given("i_deg")), all_of(given("e"), given("i_deg")))))

    a_km: float | None = Field(None, gt=MOON_RADIUS_KM, description="semi-major axis, above the lunar radius; or "
                               "give altitude_km (km)")
    altitude_km: float | None = Field(None, gt=0, description="instead of a_km: the perilune's altitude above the "
                                      f"mean lunar radius ({MOON_RADIUS_KM} km); with e = 0 a circular orbit's "
                                      "altitude (km)")
    e: float | None = Field(None, ge=0.0, lt=1.0, description="eccentricity; the perilune a_km (1 - e) must clear "
                            "the lunar radius; with frozen: true, give e or i_deg (dimensionless)")
    i_deg: float | None = Field(None, ge=0.0, le=180.0, description="inclination to the Earth-Moon orbit plane (dated: "
                                "to the lunar equator); with frozen: true, give e or i_deg (deg)")
    raan_deg: float = Field(0.0, description="right ascension of the ascending node (deg)")
    argp_deg: float | None = Field(None, description="argument of perilune (default 0; frozen: 90 or 270, default 90) "
                                   "(deg)")
    ta_deg: float = Field(0.0, description="true anomaly at t0 (deg)")
    frozen: bool = Field(False, description="an elliptical frozen orbit: the one of e / i_deg not given is solved so "
                         "that the perilune stays put (orbits.frozen; docs/orbits.md)")

    @property
    def semi_major_axis_km(self) -> float:
        """a_km, or the one altitude_km gives: (lunar radius + altitude) / (1 - e)."""
        return self.a_km if self.a_km is not None else (MOON_RADIUS_KM + self.altitude_km) / (1.0 - self.eccentricity)

    @property
    def eccentricity(self) -> float:
        """e, or the frozen one for i_deg."""
        return self.e if self.e is not None else self._frozen()[1]

    @property
    def inclination_deg(self) -> float:
        """i_deg, or the frozen (prograde) one for e."""
        return self.i_deg if self.i_deg is not None else self._frozen()[2]

    def _frozen(self) -> tuple[float, float, float]:
        """(a_km, e, i_deg) of the frozen orbit these elements name (orbits.frozen.frozen_elements, cached)."""
        from liaison_cli.dynamics.lunar_gravity import lunar_j2

        return frozen_elements(*lunar_j2(), self.argument_of_perilune_deg % 360.0, e=self.e, i_deg=self.i_deg,
                               a_km=self.a_km, perilune_altitude_km=self.altitude_km)

    @property
    def argument_of_perilune_deg(self) -> float:
        return self.argp_deg if self.argp_deg is not None else (90.0 if self.frozen else 0.0)

    @model_validator(mode="after")
    def _perilune_above_surface(self):
        if (self.a_km is None) == (self.altitude_km is None):
            raise ValueError("give the orbit's size as a_km or as altitude_km (one of the two)")
        if self.frozen:
            if (self.e is None) == (self.i_deg is None):
                raise ValueError("frozen: true: give e or i_deg (one of the two); the other is solved")
            if self.argument_of_perilune_deg % 360.0 not in (90.0, 270.0):
                raise ValueError(f"frozen: true: argp_deg = {self.argp_deg:g}; allowed: 90 (the perilune at its "
                                 "northernmost) or 270 (at its southernmost)")
            try:
                self.eccentricity, self.inclination_deg
            except NoFrozenOrbit as exc:
                raise ValueError(f"frozen: true: {exc}") from None
        elif self.e is None or self.i_deg is None:
            raise ValueError("give e and i_deg (or frozen: true and one of them)")
        if self.semi_major_axis_km * (1.0 - self.eccentricity) <= MOON_RADIUS_KM:
            raise ValueError(
                f"perilune a_km*(1-e) = {self.semi_major_axis_km * (1 - self.eccentricity):.1f} km is inside the Moon "
                f"(radius {MOON_RADIUS_KM} km)"
            )
        return self


class ClockSpec(StrictModel):
    """A participant's clock: the two-state phase / frequency model (dynamics.clock, 002 Eq. 13-16) with its
    diffusion coefficients (given, or from a named `preset` of dynamics.clock_presets; a given value
    overrides the preset's), deterministic drifts mu1 (s/s) and mu2 (aging, 1/s), and the a-priori spread
    of its initial offset and frequency (the truth draws from it, the filter starts at zero with that
    covariance)."""

    RULES: ClassVar[tuple] = (Rule(
        any_of(given("preset"), all_of(given("sigma1_s_per_sqrt_s"), given("sigma2_per_sqrt_s"))),
        "give a 'preset' (" + ", ".join(clock_preset_names()) + ") or both 'sigma1_s_per_sqrt_s' and "
        "'sigma2_per_sqrt_s'"),)
    model_config = ConfigDict(json_schema_extra=schema_rules(*RULES))

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
    def _rules(self):
        return check_rules(self, self.RULES)

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

    RULES: ClassVar[tuple] = (
        Rule(when(given("mission"), all_of(*map(not_given, _TARGETS))),
             lambda spec: f"mission {spec.mission!r} derives c3_km2_s2 / dla_deg / rla_deg; remove them"),
        Rule(when(not_given("mission"), all_of(*map(given, _TARGETS))),
             "give a mission, or all of c3_km2_s2, dla_deg and rla_deg"))
    model_config = ConfigDict(json_schema_extra=schema_rules(*RULES))

    mission: str | None = Field(None, description="one of 003's missions, whose C3, DLA, RLA, parking altitude and "
                                "injection time are derived on DE421 (instead of c3_km2_s2, dla_deg, rla_deg, "
                                "periapsis_altitude_km and time_from_periapsis_s)",
                                json_schema_extra=lambda schema: allowed_names(schema, "mission"))
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
        check_rules(self, self.RULES)
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

    RULES: ClassVar[tuple] = (
        ONE_PROCESS_NOISE_CONVENTION,
        Rule(when(equals("orbit", KEPLERIAN_ORBIT), given("elements")),
             f"orbit {KEPLERIAN_ORBIT!r} needs an 'elements' mapping"),
        Rule(when(negate(equals("orbit", KEPLERIAN_ORBIT)), not_given("elements")),
             f"'elements' is only allowed with orbit {KEPLERIAN_ORBIT!r}"),
        Rule(when(equals("orbit", *family_names()), one_of(given("period_days"), given("amplitude_km"))),
             lambda spec: f"orbit family {spec.orbit!r} needs exactly one of 'period_days' or 'amplitude_km'"),
        Rule(when(negate(equals("orbit", *family_names())), all_of(not_given("period_days"), not_given("amplitude_km"))),
             f"'period_days' / 'amplitude_km' are only allowed with an orbit family ({', '.join(family_names())})"),
        Rule(together(equals("orbit", ICRF_STATE_ORBIT), "state_km")[0],
             f"orbit {ICRF_STATE_ORBIT!r} and 'state_km' (6 numbers) go together"),
        Rule(together(equals("orbit", DEPARTURE_ORBIT), "departure")[0],
             f"orbit {DEPARTURE_ORBIT!r} and a 'departure' section go together"),
        Rule(together(equals("orbit", GEOSTATIONARY_ORBIT), "longitude_deg")[0],
             f"orbit {GEOSTATIONARY_ORBIT!r} and 'longitude_deg' go together"),
        Rule(when(equals("role", "known"), not_given("manoeuvre")),
             "a manoeuvre is solved for by the filter: give it to an estimated spacecraft"),
        Rule(when(equals("orbit", GEOSTATIONARY_ORBIT), equals("role", "known")),
             f"orbit {GEOSTATIONARY_ORBIT!r} is station-kept, not flown by the filter's dynamics: give it role: known"),
        Rule(when(equals("orbit", *UNPHASED_ORBITS), {"properties": {"phase": {"const": 0}}}),
             lambda spec: f"'phase' advances a periodic orbit (catalog or family), not orbit {spec.orbit!r}"),
        Rule(when(equals("role", "known"), not_given("clock")),
             "a known spacecraft's clock is not estimated; remove 'clock' or make it role: estimated"))
    model_config = ConfigDict(json_schema_extra=schema_rules(*RULES))

    name: str = Field(pattern=NAME_PATTERN, max_length=NAME_MAX_LENGTH, description="unique among spacecraft and "
                      "ground stations, ignoring case; letters, digits, '_', '.', '-'; at most "
                      f"{NAME_MAX_LENGTH} characters")
    role: Literal["estimated", "known"] = Field(
        "estimated", description="estimated by the filter, or known (its true trajectory is given to the filter)")
    orbit: str = Field(description="a catalog orbit; an orbit family (with period_days or amplitude_km); "
                       f"{KEPLERIAN_ORBIT} (with elements); with dynamics: ephemeris also {ICRF_STATE_ORBIT} "
                       f"(with state_km), {DEPARTURE_ORBIT} (with departure), {GEOSTATIONARY_ORBIT} (with "
                       "longitude_deg) or {opm: FILE}; {oem: FILE} (dated: ICRF, GCRF or EME2000; CRTBP: liaison's "
                       "rotating-frame export with MET tags)",
                       json_schema_extra=lambda schema: orbit_json_schema(schema, [
                           *catalog_names(), KEPLERIAN_ORBIT, *family_names(), *DATED_ONLY_ORBITS, "oem"]))
    elements: KeplerianElements | None = Field(None, description=f"orbit: {KEPLERIAN_ORBIT}: its elements")
    period_days: float | None = Field(None, gt=0, description="orbit: <family>: the member of this period (days)")
    amplitude_km: float | None = Field(None, gt=0, description="orbit: <family>: the member of this amplitude, Az "
                                       "(spatial families) or Ay (planar) (km)")
    antenna_baseline_m: float | None = Field(None, gt=0, description="interferometer baseline of the receiver, "
                                             "needed to measure LOS angles (m)")
    process_noise_psd_m2_s3: float | None = Field(
        None, ge=0, description="this spacecraft's SNC as an isotropic white-acceleration PSD (as "
        "filter.process_noise_psd_m2_s3); overrides the filter's key of either convention; not with this "
        "spacecraft's process_noise_accel_m_s2 (m^2/s^3)"
    )
    process_noise_accel_m_s2: float | None = Field(
        None, ge=0, description="this spacecraft's per-step sigma_a (as filter.process_noise_accel_m_s2: q = "
        "sigma_a^2 dt, the reproductions' convention); overrides the filter's key of either convention; not with "
        "this spacecraft's process_noise_psd_m2_s3 (m/s^2)"
    )
    process_noise_psd_ric_m2_s3: RicDensities | None = Field(
        None, description="this spacecraft's SNC as a PSD per radial / in-track / cross-track axis (as "
        "filter.process_noise_psd_ric_m2_s3); overrides the filter's key of any convention; not with this "
        "spacecraft's other process-noise keys (m^2/s^3)")
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
    orbit_file: OrbitFileSpec | None = Field(None, description="orbit: {oem: FILE} (either dynamics) or {opm: FILE} "
                                             "(dynamics: ephemeris), read into this key (docs/exchange.md)")

    @model_validator(mode="before")
    @classmethod
    def _orbit_from_file(cls, data):
        return orbit_file_from_mapping(data)

    @field_validator("orbit")
    @classmethod
    def _known_orbit(cls, value):
        allowed = [*catalog_names(), KEPLERIAN_ORBIT, *family_names(), *DATED_ONLY_ORBITS, "oem"]
        if value not in allowed:
            raise ValueError(f"unknown orbit {value!r}; allowed: {', '.join(allowed)}")
        return value

    @model_validator(mode="after")
    def _rules_then_what_rules_cannot_say(self):
        """The declared RULES, then what needs arithmetic or a file: the orbit file's mapping, an OEM with a
        manoeuvre, the ICRF state's length and radius."""
        check_rules(self, self.RULES)
        if (self.orbit in ORBIT_FILE_KINDS) != (self.orbit_file is not None):
            raise ValueError("orbit: {oem: FILE} or {opm: FILE} is given as a mapping with the file")
        if self.orbit == "oem" and self.manoeuvre is not None:
            raise ValueError("an OEM truth already holds its manoeuvres: remove 'manoeuvre' or use orbit: {opm: FILE}")
        if self.state_km is not None and len(self.state_km) != 6:
            raise ValueError(f"'state_km' needs 6 numbers (x, y, z km, vx, vy, vz km/s), got {len(self.state_km)}")
        if self.state_km is not None:
            radius_km = sum(x * x for x in self.state_km[:3]) ** 0.5
            if radius_km <= WGS84_EQUATORIAL_RADIUS_KM:
                raise ValueError(f"'state_km' puts the spacecraft {radius_km:.1f} km from the Earth's centre, inside "
                                 f"the Earth; allowed: a geocentric position above {WGS84_EQUATORIAL_RADIUS_KM} km")
        return self


class GroundStationSpec(StrictModel):
    """A station on the rotating Earth (dynamics.ground_station): WGS84 geodetic coordinates, the longitude east
    of the Earth-Moon line at t0 in the CRTBP, the true longitude with dynamics: ephemeris; it sees spacecraft
    above its elevation mask. Give either `site` or latitude_deg and longitude_deg."""

    model_config = ConfigDict(json_schema_extra=schema_rules(
        any_of(given("site"), all_of(given("latitude_deg"), given("longitude_deg"))),
        optional=("latitude_deg", "longitude_deg")))

    name: str = Field(pattern=NAME_PATTERN, max_length=NAME_MAX_LENGTH, description="unique among spacecraft and "
                      "ground stations, ignoring case; letters, digits, '_', '.', '-'; at most "
                      f"{NAME_MAX_LENGTH} characters")
    site: str | None = Field(None, description="a named site (dynamics: ephemeris), a DSN 70 m antenna or a VLBA "
                             "dish: its coordinates instead of latitude_deg / longitude_deg / altitude_m",
                             json_schema_extra=lambda schema: allowed_names(schema, "site"))
    latitude_deg: float = Field(ge=-90.0, le=90.0, description="geodetic latitude, WGS84 (deg)")
    longitude_deg: float = Field(ge=-180.0, le=360.0, description="longitude east: of the Earth-Moon line at t0 in "
                                 "the CRTBP, true with dynamics: ephemeris (deg)")
    altitude_m: float = Field(0.0, ge=-500.0, le=9000.0, description="height above the WGS84 ellipsoid (m)")
    elevation_mask_deg: float = Field(10.0, ge=-90.0, lt=90.0, description="the station measures spacecraft above "
                                      "this elevation; -90: no horizon at all, an idealised station that sees "
                                      "through the Earth (with the links' occultation off: always visible, as "
                                      "a covariance analysis with a geocentric station assumes) (deg)")

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
