"""The dated pieces of a `dynamics: ephemeris` scenario (003): the model, the initial states, the stations.

- Model: DE421 (the window of the scenario's dates), the Earth's, Moon's, Sun's and the planets' point
  masses, and the SRP cannonball C_R A/m of the `ephemeris` section (one for all spacecraft today); the
  filter's model keeps only `ephemeris.filter_bodies` (003: the Moon and the Sun).
- Initial states: a catalog orbit (a CRTBP state) is mapped to patch points every node_spacing_days over
  the scenario and corrected by multiple shooting into the dated model (003's continuity criterion); its
  first node is the initial state. A correction that does not converge is tried again with other node
  spacings (RETRY_NODE_SPACINGS_DAYS) before the error lists what was tried. `orbit: icrf_state` takes `state_km` as given; `orbit: departure` puts
  the spacecraft on its hyperbola (orbits.departure, orbits.departure_missions).
- Stations: WGS84 geodetic coordinates (true longitude) on the IAU 2006/2000A Earth with UT1 and polar
  motion from the IERS file (dynamics.earth_rotation), sampled at the scenario's epochs.
- Time: a span past the IERS tables runs by the rule of dynamics.timescales / dynamics.iers_eop (held
  values); `note_table_extrapolation` logs that once per process, as a note, on the `liaison` logger.
States are in the estimators' scaled units (LU, LU/TU), geocentric ICRF.
"""

import logging
from datetime import timedelta

import numpy as np

from liaison_cli.dynamics.constants import AU_KM_S2, EARTH_ROTATION_RATE_RAD_S, SECONDS_PER_DAY
from liaison_cli.dynamics.earth_rotation import itrf_to_gcrf_many, stations_gcrf
from liaison_cli.dynamics.ephemeris import BODY_EARTH, GM_KM3_S2, load_window
from liaison_cli.dynamics.ephemeris_model import SCALE, EphemerisDynamicsModel
from liaison_cli.dynamics.timescales import utc_to_tdb_seconds
from liaison_cli.errors import OrbitCorrectionError
from liaison_cli.orbits.departure import departure_state_km as departure_state_km_at
from liaison_cli.orbits.departure_missions import (
    DEPARTURE_MISSIONS,
    derived_launch_targets,
    parking_inclination_deg,
    periapsis_radius_km,
)
from liaison_cli.orbits.corrected_store import corrected_orbit
from liaison_cli.orbits.ephemeris_correction import POSITION_TOLERANCE_KM, VELOCITY_TOLERANCE_KM_S, ForceModel
from liaison_cli.scenario.reference_states import period_tu, phased_state_lu
from liaison_cli.scenario.participants import KEPLERIAN_ORBIT

# Patch-point spacings tried, nearest the scenario's own first, when a correction does not converge.
RETRY_NODE_SPACINGS_DAYS = (0.75, 1.0, 1.5, 2.0, 3.0)
THIRD_BODIES = (301, 10, 1, 2, 4, 5, 6, 7, 8, 9)  # Moon, Sun, the planets' systems
BODY_CODES = {"moon": 301, "sun": 10, "mercury": 1, "venus": 2, "mars": 4, "jupiter": 5, "saturn": 6, "uranus": 7,
              "neptune": 8, "pluto": 9}


_NOTED: set = set()


def note_table_extrapolation(scenario) -> None:
    """Log (once per process and sentence) that the scenario's span lies past the IERS leap-second file or
    Earth orientation predictions, and by which rule it runs."""
    from liaison_cli.dynamics.iers_eop import beyond_table_note
    from liaison_cli.dynamics.timescales import beyond_leap_seconds_note

    end = scenario.ephemeris.epoch() + timedelta(days=scenario.duration_days)
    for note in (beyond_leap_seconds_note(end), beyond_table_note(end)):
        if note is not None and note not in _NOTED:
            _NOTED.add(note)
            logging.getLogger("liaison").warning("%s: %s", scenario.name, note)


def dated_model(scenario) -> EphemerisDynamicsModel:
    spec = scenario.ephemeris
    note_table_extrapolation(scenario)
    epoch_s = utc_to_tdb_seconds(spec.epoch())
    window = load_window(epoch_s, epoch_s + scenario.duration_days * SECONDS_PER_DAY)
    bodies = np.array(THIRD_BODIES, dtype=np.int64)
    gms = np.array([GM_KM3_S2[b] for b in THIRD_BODIES])
    filter_bodies = [BODY_CODES[name] for name in spec.filter_bodies]
    return EphemerisDynamicsModel(window, bodies, gms, GM_KM3_S2[BODY_EARTH], spec.cr * spec.area_to_mass_m2_kg, epoch_s,
                                  filter_bodies,
                                  np.asarray(scenario.model_error.truth_acceleration_m_s2, dtype=float) * 1e-3,
                                  *moon_fields(scenario.moon_gravity))


def moon_fields(gravity) -> tuple[np.ndarray, np.ndarray | None]:
    """(the truth's terms table, the filter's or None for the truth's) of a scenario's moon_gravity section (None:
    a point-mass Moon in both; ephemeris_dynamics.dated_terms)."""
    from liaison_cli.dynamics.ephemeris_dynamics import NO_TERMS, dated_terms, moon_harmonics_term, moon_j2_term
    from liaison_cli.dynamics.lunar_gravity import lunar_field, lunar_j2

    if gravity is None:
        return NO_TERMS, None
    truth = dated_terms(moon_harmonics_term(lunar_field(gravity.degree)))
    if gravity.filter_field == "j2":
        return truth, dated_terms(moon_j2_term(*lunar_j2()))
    degree = gravity.filter_degree_or_truth
    if degree == gravity.degree:
        return truth, None
    return truth, dated_terms(moon_harmonics_term(lunar_field(degree) if degree else None))


def departure_from_spec_km(spec, epoch_utc) -> np.ndarray:
    """The departure's geocentric ICRF state (6,) km, km/s at the scenario epoch."""
    if spec.mission is None:
        c3, dla, rla = spec.c3_km2_s2, spec.dla_deg, spec.rla_deg
        altitude_km, since_periapsis_s = spec.periapsis_altitude_km, spec.time_from_periapsis_s
    else:
        mission = DEPARTURE_MISSIONS[spec.mission]
        c3, dla, rla = derived_launch_targets(mission)
        altitude_km = mission.parking_altitude_km
        periapsis = mission.start_utc_datetime() - timedelta(seconds=mission.time_from_periapsis_s())
        since_periapsis_s = (epoch_utc - periapsis).total_seconds()
        if since_periapsis_s < 0:
            raise ValueError(f"departure mission {spec.mission!r}: the scenario epoch is {-since_periapsis_s:.0f} s "
                             f"before its injection ({periapsis.isoformat()})")
    inclination = spec.parking_inclination_deg or parking_inclination_deg(dla)
    return departure_state_km_at(c3, dla, rla, periapsis_radius_km(altitude_km), since_periapsis_s, inclination,
                                 spec.branch)


def dated_initial_state_lu(spacecraft, scenario, model: EphemerisDynamicsModel) -> np.ndarray:
    if spacecraft.state_km is not None:
        return np.asarray(spacecraft.state_km, dtype=float) / SCALE
    if spacecraft.orbit_file is not None:  # an OPM (an OEM's truth is read whole, scenario.orbit_files)
        from liaison_cli.scenario.orbit_files import opm_state_lu

        return opm_state_lu(spacecraft, model.epoch_tdb_s)
    if spacecraft.departure is not None:
        return departure_from_spec_km(spacecraft.departure, scenario.ephemeris.epoch()) / SCALE
    if spacecraft.orbit == KEPLERIAN_ORBIT:
        return lunar_orbiter_state_km(spacecraft.elements, model) / SCALE
    return corrected_nodes_lu(spacecraft, scenario, model)[1][0]


def lunar_orbiter_state_km(elements, model: EphemerisDynamicsModel) -> np.ndarray:
    """The geocentric ICRF state (6,) km, km/s at the epoch of a lunar orbiter's Moon-centred elements. Their axes
    are the CRTBP's (orbits.keplerian: the rotating frame's at t0, where the CRTBP's Moon has its principal axes
    at x_PA = -x, y_PA = -y, z_PA = z): here the Moon's principal axes at the epoch (dynamics.lunar_orientation)
    turned the same way, so an inclination is measured from the lunar equator in both models. The Moon's GM is
    the model's (DE421's)."""
    from liaison_cli.dynamics.lunar_orientation import moon_pa_from_icrf
    from liaison_cli.orbits.keplerian import elements_to_moon_inertial

    r_km, v_km_s = elements_to_moon_inertial(elements.semi_major_axis_km, elements.eccentricity,
                                             elements.inclination_deg, elements.raan_deg,
                                             elements.argument_of_perilune_deg, elements.ta_deg, model.moon_gm_km3_s2)
    icrf_from_axes = moon_pa_from_icrf(model.epoch_tdb_s).T @ np.diag([-1.0, -1.0, 1.0])
    moon = model.moon_states_km(np.zeros(1))[0]
    return moon + np.concatenate([icrf_from_axes @ r_km, icrf_from_axes @ v_km_s])


def is_corrected(spacecraft) -> bool:
    """The spacecraft flies a catalog or family orbit corrected into the dated model (not a given state, an
    orbit file, a departure or a lunar orbiter's elements, which are flown from the epoch)."""
    return (spacecraft.state_km is None and spacecraft.orbit_file is None and spacecraft.departure is None
            and spacecraft.orbit != KEPLERIAN_ORBIT)


def corrected_nodes_lu(spacecraft, scenario, model: EphemerisDynamicsModel) -> tuple[np.ndarray, np.ndarray]:
    """(node times (N + 1,) s from the scenario epoch, nodes (N + 1, 6) scaled): the spacecraft's catalog orbit
    corrected by multiple shooting into the dated model over the scenario, at its node spacing or, failing
    that, the others tried (RETRY_NODE_SPACINGS_DAYS); OrbitCorrectionError when none converges."""
    forces = ForceModel(model.window, model.bodies, model.gms, model.gm_earth, model.cr_am, model.terms)
    span_s = scenario.duration_days * SECONDS_PER_DAY
    tried = []
    for spacing_days in node_spacings_to_try(scenario.ephemeris.node_spacing_days):
        spacing_s = min(spacing_days * SECONDS_PER_DAY, span_s)
        corrected, _ = corrected_orbit(phased_state_lu(spacecraft), model.epoch_tdb_s, span_s, spacing_s, forces,
                                       period_tu=reference_period_tu(spacecraft))
        if corrected.converged:
            return corrected.node_times_s - model.epoch_tdb_s, corrected.nodes / SCALE
        tried.append(f"{spacing_days:g} d: {corrected.position_defects_km[-1]:.3g} km, "
                     f"{corrected.velocity_defects_km_s[-1] * 1e3:.3g} m/s after {corrected.iterations} iterations")
    raise OrbitCorrectionError(
        f"{scenario.name}: spacecraft {spacecraft.name!r}: multiple shooting of {spacecraft.orbit!r} over "
        f"{scenario.duration_days:g} d did not converge to {POSITION_TOLERANCE_KM * 1e3:g} m and "
        f"{VELOCITY_TOLERANCE_KM_S * 1e3:g} m/s; node spacings tried (largest defects left): {'; '.join(tried)}. "
        "A shorter scenario, or another epoch, may have a nearby orbit in the dated model")


def reference_period_tu(spacecraft) -> float | None:
    """The period of the spacecraft's catalog or family orbit (TU), along which its patch points are taken
    (orbits.ephemeris_correction.along_orbit); None for a Keplerian orbit about the Moon, not periodic in the
    CRTBP."""
    return None if spacecraft.orbit == KEPLERIAN_ORBIT else period_tu(spacecraft)


def node_spacings_to_try(requested_days: float) -> list[float]:
    """The scenario's node spacing, then the others of RETRY_NODE_SPACINGS_DAYS nearest to it first."""
    others = sorted((d for d in RETRY_NODE_SPACINGS_DAYS if d != requested_days), key=lambda d: abs(d - requested_days))
    return [requested_days, *others]


class DatedStationTrajectory:
    """A station's GCRF states (m, 6) in scaled units and its up vectors (m, 3) at the scenario's epochs.
    The Earth's orientation at those epochs is computed once per scenario and shared by its stations.
    Accelerations (m, 3), LU/TU^2: the centripetal a = w x v of the Earth's spin w about its axis (the
    ITRF z axis turned into the GCRF), as the velocity is w x r (dynamics.earth_rotation.stations_gcrf)."""

    rotating_frame = False

    def __init__(self, latitude_deg, longitude_deg, altitude_m, epoch_utc, times_s):
        rotations = _earth_orientation(epoch_utc, times_s)
        r, v, up = stations_gcrf(latitude_deg, longitude_deg, altitude_m, rotations)
        self.states = np.hstack([r, v]) / SCALE
        self.up = up
        spin_rad_s = EARTH_ROTATION_RATE_RAD_S * rotations[:, :, 2]
        self.accelerations = np.cross(spin_rad_s, v) / AU_KM_S2


_ORIENTATION: dict = {}


def _earth_orientation(epoch_utc, times_s) -> np.ndarray:
    """itrf_to_gcrf at epoch + times_s (m, 3, 3), kept for the last few scenarios' epoch grids."""
    times_s = np.asarray(times_s, dtype=float)
    key = (epoch_utc.isoformat(), times_s.tobytes())
    if key not in _ORIENTATION:
        if len(_ORIENTATION) >= 4:
            _ORIENTATION.pop(next(iter(_ORIENTATION)))
        _ORIENTATION[key] = itrf_to_gcrf_many([epoch_utc + timedelta(seconds=float(t)) for t in times_s])
    return _ORIENTATION[key]
