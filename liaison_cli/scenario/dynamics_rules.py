"""The scenario's rules about its dynamics, written once and grouped here: what the dynamics model
(dynamics.registry) and the ephemeris section allow, the model_error section against the model, and the
parameters the filter may estimate (filter.estimated_parameters), each asked of the model's descriptor; and the
filter states and process noise that lean on the model (filter.empirical_acceleration on its axes, a RIC
process noise about its primaries). Scenario._consistent calls check_dynamics, check_model_error,
check_estimated_parameters, check_empirical_acceleration and check_ric_process_noise; each raises ValueError
with one line naming the key, its value and what is allowed."""

from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.dynamics.registry import DYNAMICS
from liaison_cli.estimation.estimators import ESTIMATORS
from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.orbits.departure import MAX_TIME_FROM_PERIAPSIS_S
from liaison_cli.scenario.participants import DATED_ONLY_ORBITS, GEOSTATIONARY_ORBIT


def check_dynamics(scenario) -> None:
    """What the scenario's dynamics model allows (its descriptor says whether its epochs are dates), and an
    estimator that runs it."""
    if scenario.dynamics not in scenario.estimator_descriptor().dynamics:
        runners = " / ".join(name for name, e in ESTIMATORS.items() if scenario.dynamics in e.dynamics)
        raise ValueError(f"dynamics: {scenario.dynamics} runs the {runners} today (estimator: {runners})")
    if scenario.moon_gravity is not None and not scenario.dynamics_descriptor().lunar_field:
        capable = " / ".join(d.name for d in DYNAMICS.values() if d.lunar_field)
        raise ValueError(f"moon_gravity: dynamics: {scenario.dynamics} keeps a point-mass Moon; the lunar field "
                         f"runs with dynamics: {capable}")
    if scenario.dynamics_descriptor().dated:
        _check_dated(scenario)
    else:
        _check_undated(scenario)


def _check_undated(scenario):
    """CRTBP: no true Earth sites, no ephemeris section, no dated orbits."""
    for i, st in enumerate(scenario.ground_stations):
        if st.site is not None:
            raise ValueError(f"ground_stations[{i}].site = {st.site!r} needs dynamics: ephemeris (CRTBP "
                             "stations take a longitude from the Earth-Moon line, not a true one)")
    if scenario.ephemeris is not None:
        raise ValueError("an 'ephemeris' section needs dynamics: ephemeris")
    for i, sc in enumerate(scenario.spacecraft):
        if sc.orbit in DATED_ONLY_ORBITS:
            raise ValueError(f"spacecraft[{i}].orbit = {sc.orbit!r} needs dynamics: ephemeris")


def _check_dated(scenario):
    """The dated model: its epoch inside DE421 (and the IERS table where the Earth turns), an estimator that
    runs it, the observables and orbits it takes."""
    if scenario.ephemeris is None:
        raise ValueError("key 'dynamics' = 'ephemeris' needs an 'ephemeris' section with its epoch_utc")
    from liaison_cli.dynamics.ephemeris import de421_span_s
    from liaison_cli.dynamics.timescales import utc_to_tdb_seconds

    try:
        start = utc_to_tdb_seconds(scenario.ephemeris.epoch())
    except ValueError as exc:
        raise ValueError(f"ephemeris.epoch_utc = {scenario.ephemeris.epoch_utc!r}: {exc}") from None
    lo, hi = de421_span_s()
    if start < lo or start + scenario.duration_days * SECONDS_PER_DAY > hi:
        raise ValueError(f"ephemeris.epoch_utc = {scenario.ephemeris.epoch_utc!r} plus {scenario.duration_days:g} d is "
                         "outside DE421 (1899-07-29 to 2053-10-09)")
    _check_earth_orientation(scenario)
    timed = [o for link in scenario.links for o in link.observables if not OBSERVABLES[o].light_time_from_states]
    if scenario.measurement.light_time and timed:
        raise ValueError(f"dynamics: ephemeris takes measurement.light_time: true for tdoa / fdoa only; "
                         f"{timed[0]!r} is instantaneous there (measurement.light_time: false)")
    for i, link in enumerate(scenario.links):
        unsupported = [o for o in link.observables if OBSERVABLES[o].channels[0].unit not in ("m", "m/s", "s")
                       or OBSERVABLES[o].needs_receiver_clock or OBSERVABLES[o].needs_both_clocks]
        if unsupported:
            raise ValueError(f"links[{i}]: dynamics: ephemeris takes range, range-rate, tdoa and fdoa links today; got "
                             f"{', '.join(unsupported)}")
    _check_departures(scenario)

def _check_earth_orientation(scenario):
    """Ground stations and geostationary spacecraft turn with the Earth: their epochs need the IERS table
    (dynamics.iers_eop), which begins on 1973-01-02; later epochs past its end run by a stated rule."""
    turning = scenario.ground_stations or any(sc.orbit == GEOSTATIONARY_ORBIT for sc in scenario.spacecraft)
    if not turning or scenario.ephemeris.epoch().year > 1973:  # reading the table costs 0.25 s: only near its start
        return
    from liaison_cli.dynamics.iers_eop import first_day

    if scenario.ephemeris.epoch() < first_day():
        raise ValueError(f"ephemeris.epoch_utc = {scenario.ephemeris.epoch_utc!r} is before the IERS Earth orientation "
                         f"table ({first_day():%Y-%m-%d}), which ground stations and geostationary spacecraft "
                         "need; allowed: an epoch from then on")

def _check_departures(scenario):
    from datetime import timedelta

    from liaison_cli.orbits.departure_missions import DEPARTURE_MISSIONS

    for i, sc in enumerate(scenario.spacecraft):
        if sc.departure is None or sc.departure.mission is None:
            continue
        mission = DEPARTURE_MISSIONS[sc.departure.mission]
        injection = mission.start_utc_datetime() - timedelta(seconds=mission.time_from_periapsis_s())
        if scenario.ephemeris.epoch() < injection:
            raise ValueError(f"spacecraft[{i}].departure.mission = {sc.departure.mission!r}: the scenario epoch "
                             f"{scenario.ephemeris.epoch_utc} is before its injection "
                             f"({injection.strftime('%Y-%m-%dT%H:%M:%S')} UTC)")
        last = injection + timedelta(seconds=MAX_TIME_FROM_PERIAPSIS_S)
        if scenario.ephemeris.epoch() > last:
            raise ValueError(f"ephemeris.epoch_utc = {scenario.ephemeris.epoch_utc!r} is "
                             f"{(scenario.ephemeris.epoch() - injection).total_seconds() / 3600:.5g} h after the "
                             f"injection of spacecraft[{i}].departure.mission = {sc.departure.mission!r}; allowed: "
                             f"{injection.strftime('%Y-%m-%dT%H:%M:%S')} to {last.strftime('%Y-%m-%dT%H:%M:%S')} "
                             "UTC (the two-body departure hyperbola holds for 3 h after periapsis)")


def check_model_error(scenario) -> None:
    """model_error's C_R errors need a model with a C_R (its descriptor's parameters); one spelling of the C_R
    sigma; a lunar GM error needs the filter's Moon."""
    error = scenario.model_error
    if scenario.dynamics_descriptor().parameter("cr") is None and (error.cr_bias or error.cr_sigma):
        raise ValueError("model_error.cr_bias / cr_sigma need dynamics: ephemeris (the CRTBP has no solar "
                         "radiation pressure); allowed for the CRTBP: moon_gm_bias, moon_gm_sigma")
    if scenario.ephemeris is not None and scenario.ephemeris.cr_error_sigma and error.cr_sigma:
        raise ValueError("ephemeris.cr_error_sigma and model_error.cr_sigma are the same setting: give one")
    if (error.moon_gm_bias or error.moon_gm_sigma) and scenario.ephemeris is not None \
            and "moon" not in scenario.ephemeris.filter_bodies:
        raise ValueError("model_error.moon_gm_bias / moon_gm_sigma change the filter's Moon, which "
                         "ephemeris.filter_bodies leaves out; allowed: with 'moon' among the filter's bodies")
    if any(error.truth_acceleration_m_s2):
        _check_truth_acceleration(scenario, f"truth_acceleration_m_s2 = {list(error.truth_acceleration_m_s2)}",
                                  scenario.spacecraft)
    if error.truth_acceleration_sigma_m_s2 > 0.0:
        _check_random_truth_acceleration(scenario)
    elif (error.truth_acceleration_time_constant_s is not None
          and "truth_acceleration_sigma_m_s2" not in error.model_fields_set):  # an explicit 0 (a sweep's) is none
        raise ValueError(f"model_error.truth_acceleration_time_constant_s = "
                         f"{error.truth_acceleration_time_constant_s:g} without truth_acceleration_sigma_m_s2: "
                         "no random acceleration to correlate; allowed: both (a sigma of 0: no force), or neither")


def _check_random_truth_acceleration(scenario) -> None:
    """The random truth acceleration needs its time constant, no shorter than the measurement interval (the
    process is sampled at the epochs), simulated measurements (a file's have their own truth), and estimated
    spacecraft whose truth liaison propagates."""
    error, interval_s = scenario.model_error, scenario.measurement.interval_s
    tau, sigma = error.truth_acceleration_time_constant_s, error.truth_acceleration_sigma_m_s2
    if tau is None:
        raise ValueError(f"model_error.truth_acceleration_time_constant_s is missing: with "
                         f"truth_acceleration_sigma_m_s2 = {sigma:g} it is needed; allowed: from "
                         f"measurement.interval_s = {interval_s:g} s up (the process is sampled at the epochs)")
    if tau < interval_s:
        raise ValueError(f"model_error.truth_acceleration_time_constant_s = {tau:g}: allowed from "
                         f"measurement.interval_s = {interval_s:g} s up (the process is sampled at the measurement "
                         "epochs)")
    key = f"truth_acceleration_sigma_m_s2 = {sigma:g}"
    if scenario.measurements is not None:
        raise ValueError(f"model_error.{key} with measurements: {{tdm: ...}}: the file's measurements come from "
                         "their own truth, which no drawn acceleration moves; allowed: simulated measurements")
    estimated = [sc for sc in scenario.spacecraft if sc.role == "estimated"]
    _check_truth_acceleration(scenario, key, estimated)
    stationary = [sc.name for sc in estimated if sc.longitude_deg is not None]
    if stationary:
        raise ValueError(f"model_error.{key} with the station-kept geostationary "
                         f"spacecraft {stationary[0]!r} estimated: its truth is a point fixed to the Earth, which "
                         "no acceleration moves; allowed: estimated spacecraft whose truth liaison propagates")


def _check_truth_acceleration(scenario, key: str, spacecraft) -> None:
    """An unmodelled push needs a truth that is propagated: not one read from an OEM, not a corrected dated
    orbit flown node by node (each node would undo it). Station-kept geostationary spacecraft are points fixed
    to the Earth and stay exempt from the constant push (documented)."""
    for sc in spacecraft:
        i = scenario.spacecraft.index(sc)
        if sc.orbit_file is not None and sc.orbit_file.kind == "oem":
            raise ValueError(f"model_error.{key} with spacecraft[{i}].orbit = {{oem: ...}}: its "
                             "truth is the file's, which no acceleration moves; allowed: spacecraft whose truth "
                             "liaison propagates")
    if not scenario.dynamics_descriptor().dated:
        return
    from liaison_cli.scenario.dated import is_corrected

    corrected = [scenario.spacecraft.index(sc) for sc in spacecraft
                 if is_corrected(sc) and sc.longitude_deg is None and sc.manoeuvre is None]
    if corrected:
        raise ValueError(f"model_error.{key} with spacecraft[{corrected[0]}] on a corrected "
                         "orbit: its truth is flown from the corrected nodes, which would undo the acceleration "
                         "at every node; allowed: dynamics: crtbp, or dated spacecraft with a state_km, an OPM "
                         "a departure or lunar_keplerian elements")


def check_estimated_parameters(scenario) -> None:
    """filter.estimated_parameters: each name a parameter of the scenario's dynamics model (its descriptor's
    list), by an estimator that carries dynamics parameters."""
    wanted = scenario.filter.estimated_parameters
    if not wanted:
        return
    dynamics = scenario.dynamics_descriptor()
    for name in wanted:
        if dynamics.parameter(name) is None:
            allowed = ", ".join(dynamics.parameter_names) or "none"
            raise ValueError(f"filter.estimated_parameters.{name}: dynamics: {dynamics.name} has no such parameter; "
                             f"allowed: {allowed}")
    _carried_by_the_estimator(scenario, "filter.estimated_parameters", "dynamics_parameters",
                        "estimate dynamics parameters")
    if "cr" in wanted and scenario.ephemeris.cr * scenario.ephemeris.area_to_mass_m2_kg == 0.0:
        raise ValueError("filter.estimated_parameters.cr with ephemeris.area_to_mass_m2_kg = 0: no solar "
                         "radiation pressure, so no data can reach C_R; allowed: a cannonball with an area")


def check_empirical_acceleration(scenario) -> None:
    """filter.empirical_acceleration: by an estimator that carries it, with a time constant of at least one
    measurement interval (the transition exp(-dt / tau) stays above 1/e; a shorter correlation is white noise,
    which the process noise already is)."""
    spec = scenario.filter.empirical_acceleration
    if spec is None:
        return
    _carried_by_the_estimator(scenario, "filter.empirical_acceleration", "empirical_accelerations",
                        "carry empirical accelerations")
    interval_s = scenario.measurement.interval_s
    if spec.time_constant_s < interval_s:
        raise ValueError(f"filter.empirical_acceleration.time_constant_s = {spec.time_constant_s:g} is shorter than "
                         f"measurement.interval_s = {interval_s:g}: allowed: at least one interval (a shorter "
                         "correlation is white noise: use filter.process_noise_psd_m2_s3)")


def check_ric_process_noise(scenario) -> None:
    """A process noise per radial / in-track / cross-track axis (process_noise_psd_ric_m2_s3) is rebuilt at each
    step in the frame of the estimate about the nearer primary of the dynamics model; the initial batch carries
    a fixed process noise over its window, so the two do not go together."""
    if scenario.filter.initial_batch_hours is not None and scenario.filter.uses_ric_process_noise(scenario.spacecraft):
        raise ValueError("process_noise_psd_ric_m2_s3 with filter.initial_batch_hours: the initial batch takes a fixed "
                         "process noise over its window; allowed: one of the two (or process_noise_psd_m2_s3)")


def check_dead_process_noise(scenario) -> None:
    """A filter-level process-noise key applies to the estimated spacecraft that give none of their own; when
    every one of them gives its own, the filter's key applies to none (it was silently dead)."""
    from liaison_cli.scenario.spec_base import PROCESS_NOISE_KEYS

    flt = scenario.filter
    given = [key for key in PROCESS_NOISE_KEYS if getattr(flt, key) is not None]
    estimated = [sc for sc in scenario.spacecraft if sc.role == "estimated"]
    if not given or not estimated:
        return
    if all(any(getattr(sc, key) is not None for key in PROCESS_NOISE_KEYS) for sc in estimated):
        value = getattr(flt, given[0])
        shown = list(value) if isinstance(value, tuple) else value
        raise ValueError(f"filter.{given[0]} = {shown} applies to no spacecraft: every estimated spacecraft "
                         f"({', '.join(sc.name for sc in estimated)}) gives its own process noise; allowed: remove "
                         "the filter's key, or a spacecraft's own key where the filter's should apply")


def _carried_by_the_estimator(scenario, key: str, supports: str, what: str) -> None:
    """A setting that adds filter states (`key`): by an estimator whose descriptor flag `supports` is set (an
    initial batch solves for every filter state, these included)."""
    estimator = scenario.estimator_descriptor()
    if not getattr(estimator, supports):
        runners = ", ".join(e.name for e in ESTIMATORS.values() if getattr(e, supports))
        raise ValueError(f"{key}: estimator {estimator.name} does not {what}; allowed: estimator {runners}")
