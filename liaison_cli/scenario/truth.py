"""Scenario -> truth: the participants' trajectories at the measurement epochs (flown by the scenario's
dynamics, a manoeuvre applied after its epoch; stations turning with the Earth), which links see each other
when, and the noise-free measurements.

Computed once per scenario and shared (read-only) by every Monte Carlo run; a cache lets a sweep over noise
or filter settings, or over link sets, propagate the truth once. A random unmodelled acceleration
(model_error.truth_acceleration_sigma_m_s2) makes each run fly and measure its own truth
(`forced_truth_and_measurements`, called by the worker with the run's draw)."""

import hashlib
import json

import numpy as np

from liaison_cli.dynamics.constants import GEOSTATIONARY_ALTITUDE_M, M_S_PER_VU, MU, SECONDS_PER_DAY, TU_S
from liaison_cli.dynamics.ground_station import GroundStationTrajectory
from liaison_cli.dynamics.model import DynamicsModel, crtbp_model
from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.measurements.visibility import elevation_rad, not_occulted
from liaison_cli.scenario.reference_states import phased_state_lu
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.scenario.truth_store import load_truth, store_truth


def truth_key(scenario: Scenario) -> str:
    """The scenario fields that fix truth and noise-free measurements (not noise, filter or seed)."""
    return json.dumps({"trajectories": trajectory_key(scenario),
                       "links": [link.model_dump(mode="json") for link in scenario.links],
                       "station_priority": scenario.station_priority,
                       "light_time": scenario.measurement.light_time}, sort_keys=True)


def _spacecraft_fields(sc) -> dict:
    return {"orbit": sc.orbit, "elements": sc.elements and sc.elements.model_dump(), "period_days": sc.period_days,
            "amplitude_km": sc.amplitude_km, "role": sc.role, "phase": sc.phase, "longitude_deg": sc.longitude_deg,
            "departure": sc.departure and sc.departure.model_dump(),
            "manoeuvre": sc.manoeuvre and sc.manoeuvre.model_dump()}


# Under this key of a truth cache: one spacecraft's CRTBP truth, for a series of scenarios in which it flies the
# same orbit while others change (campaign.studies.design's candidates).
SPACECRAFT_CACHE = "spacecraft_truths"


def _spacecraft_truth_key(scenario: Scenario, model, sc, times_s, state0) -> str:
    """What fixes one spacecraft's CRTBP truth: its orbit fields, its initial state, the epochs and the model (its
    parameters and the truth's unmodelled acceleration)."""
    digest = hashlib.sha256(np.ascontiguousarray(model.params).tobytes()
                            + np.ascontiguousarray(model.truth_acceleration_lu_tu2).tobytes()
                            + np.ascontiguousarray(times_s, dtype=float).tobytes()
                            + np.ascontiguousarray(state0, dtype=float).tobytes()).hexdigest()
    return json.dumps({"spacecraft": _spacecraft_fields(sc), "model": model.name, "numbers": digest}, sort_keys=True)


def trajectory_key(scenario: Scenario) -> str:
    """The scenario fields that fix the participants' trajectories at the epochs (not the links)."""
    fields = {
        "spacecraft": [_spacecraft_fields(sc) for sc in scenario.spacecraft],
        "ground_stations": [st.model_dump(mode="json") for st in scenario.ground_stations],
        "duration_days": scenario.epochs_end_days(),
        "interval_s": scenario.measurement.interval_s,
        "dynamics": scenario.dynamics,
        "ephemeris": scenario.ephemeris and scenario.ephemeris.model_dump(),
        "state_km": [sc.state_km for sc in scenario.spacecraft],
        "orbit_file": [sc.orbit_file and sc.orbit_file.model_dump() for sc in scenario.spacecraft],
        "truth_acceleration_m_s2": list(scenario.model_error.truth_acceleration_m_s2),
        # the truth's lunar field (the filter's degree does not move the truth: a sweep over it shares one)
        "moon_gravity_degree": scenario.moon_gravity and scenario.moon_gravity.degree,
    }
    return json.dumps(fields, sort_keys=True)


def measurement_times_s(scenario: Scenario) -> np.ndarray:
    """Epochs t0 = 0, interval, 2 interval, ... up to the scenario duration (a batch: span + prediction) (m,)."""
    interval_s = scenario.measurement.interval_s
    n_intervals = int(np.floor(scenario.epochs_end_days() * SECONDS_PER_DAY / interval_s + 1e-9))
    return np.arange(n_intervals + 1) * interval_s


def link_observables(link) -> list:
    """The link's observables in registry order (range, range-rate, LOS, pseudorange): a channel's place
    does not depend on the order the scenario lists them in."""
    return [obs for name, obs in OBSERVABLES.items() if name in link.observables]




def _flown(scenario: Scenario, model, spacecraft, state0, times_tu, extra_lu_tu2=None) -> np.ndarray:
    """The truth (m, 6) from state0; a manoeuvre's Delta-v joins the velocity just after its epoch (the
    state at that epoch is the one before the burn). extra_lu_tu2 (m, 3): a drawn unmodelled acceleration at
    the epochs (None: none)."""
    if spacecraft.manoeuvre is None:
        return model.truth_states(state0, times_tu, extra_lu_tu2)
    k = burn_step(scenario, spacecraft.manoeuvre)
    before = model.truth_states(state0, times_tu[: k + 1], None if extra_lu_tu2 is None else extra_lu_tu2[: k + 1])
    kicked = before[-1].copy()
    kicked[3:] += np.array(spacecraft.manoeuvre.delta_v_m_s) / M_S_PER_VU
    after = model.truth_states(kicked, times_tu[k:], None if extra_lu_tu2 is None else extra_lu_tu2[k:])
    return np.vstack([before, after[1:]])


def forced_truth_and_measurements(scenario: Scenario, model: DynamicsModel, times_s, others: dict,
                                  initial_states: dict, extra_lu_tu2: dict):
    """One run's own truth under a drawn unmodelled acceleration (model_error.truth_acceleration_sigma_m_s2):
    (trajectories, noise-free measurements (m, C) with row 0 NaN). Each spacecraft of extra_lu_tu2 {name: (m, 3)
    at the epochs, LU/TU^2 on the dynamics model's axes} is flown again from initial_states[name] (6,), its
    nominal state at t0 (a manoeuvre as in the nominal truth); every other participant keeps its nominal,
    shared trajectory from `others` (unforced_participants). Visibility is recomputed on the run's own truth."""
    times_tu = times_s / TU_S
    flown = dict(others)
    for sc in scenario.spacecraft:
        if sc.name in extra_lu_tu2:
            states = _flown(scenario, model, sc, initial_states[sc.name], times_tu, extra_lu_tu2[sc.name])
            flown[sc.name] = model.trajectory(states, times_tu)
    return flown, _measured(scenario, model, times_s, flown)[2]


def unforced_participants(scenario: Scenario, trajectories: dict) -> dict:
    """{name: trajectory} of the participants a drawn truth force leaves alone (known spacecraft, ground
    stations): what each run's forced_truth_and_measurements needs besides its own spacecraft."""
    forced = set(scenario.spacecraft_names())
    return {name: trajectory for name, trajectory in trajectories.items() if name not in forced}


def _flown_from_nodes(model, node_times_s, nodes_lu, times_s) -> np.ndarray:
    """The truth (m, 6) of a corrected orbit: each epoch propagated from the last node at or before it (the
    nodes are continuous to 1 mm and 1 um/s, 10 cm and 0.1 mm/s where accepted at the rounding floor:
    ephemeris_correction's criteria). Flown from its first node
    alone, an unstable orbit leaves the corrected one: 004's 60-day EML1 halo receivers were 5-10 km off by
    day 30 and 1.1e5 km by day 54-58, no longer on a halo (measured)."""
    times_s = np.asarray(times_s, dtype=float)
    segment = np.clip(np.searchsorted(node_times_s, times_s, side="right") - 1, 0, len(node_times_s) - 1)
    out = np.empty((len(times_s), 6))
    for i in np.unique(segment):
        epochs = np.flatnonzero(segment == i)
        at_node = times_s[epochs[0]] == node_times_s[i]  # the node is an epoch (spacings are whole intervals)
        sampled = times_s[epochs] if at_node else np.concatenate([[node_times_s[i]], times_s[epochs]])
        states = model.truth_states(nodes_lu[i], sampled / TU_S)
        out[epochs] = states if at_node else states[1:]
    return out


def _trajectories(scenario: Scenario, model: DynamicsModel, times_s, flown: dict | None = None):
    """{participant name: trajectory} for every spacecraft (truth propagation) and ground station; `flown`: a
    cache of single spacecraft's CRTBP truths (SPACECRAFT_CACHE), read and filled."""
    if scenario.dynamics_descriptor().dated:
        return _dated_trajectories(scenario, model, times_s)
    times_tu = times_s / TU_S
    out = {}
    for sc in scenario.spacecraft:
        if sc.orbit_file is not None and sc.orbit_file.kind == "oem":  # the truth follows the file (a CRTBP export)
            from liaison_cli.scenario.orbit_files import crtbp_oem_truth_lu

            out[sc.name] = model.trajectory(crtbp_oem_truth_lu(sc, times_s))
            continue
        state0 = phased_state_lu(sc)
        key = _spacecraft_truth_key(scenario, model, sc, times_s, state0)
        states = flown.get(key) if flown is not None else None
        if states is None:
            states = load_truth(key, len(times_s))  # scenario.truth_store: flown once per machine
            if states is None:
                states = _flown(scenario, model, sc, state0, times_tu)
                states.setflags(write=False)  # shared between scenarios: nobody writes into it
                store_truth(key, states)
            if flown is not None:
                flown[key] = states
        out[sc.name] = model.trajectory(states)
    for st in scenario.ground_stations:
        out[st.name] = GroundStationTrajectory(st.latitude_deg, st.longitude_deg, st.altitude_m, times_tu)
    return out


def _dated_trajectories(scenario: Scenario, model, times_s):
    """_trajectories of a dated model: stations and geostationary spacecraft turn with the Earth, imported
    orbits follow their file, corrected orbits are flown from their nodes."""
    from liaison_cli.scenario.dated import (
        DatedStationTrajectory,
        corrected_nodes_lu,
        dated_initial_state_lu,
        is_corrected,
    )

    times_tu = times_s / TU_S
    out = {}
    for sc in scenario.spacecraft:
        if sc.longitude_deg is not None:  # station-kept geostationary: a point fixed to the rotating Earth
            out[sc.name] = DatedStationTrajectory(0.0, sc.longitude_deg, GEOSTATIONARY_ALTITUDE_M,
                                                  scenario.ephemeris.epoch(), times_s)
        elif sc.orbit_file is not None and sc.orbit_file.kind == "oem":  # the truth follows the file
            from liaison_cli.scenario.orbit_files import oem_truth_lu

            out[sc.name] = model.trajectory(oem_truth_lu(sc, model.epoch_tdb_s, times_s), times_tu)
        elif is_corrected(sc) and sc.manoeuvre is None:  # flown segment by segment from its corrected nodes
            out[sc.name] = model.trajectory(_flown_from_nodes(model, *corrected_nodes_lu(sc, scenario, model),
                                                              times_s), times_tu)
        else:
            out[sc.name] = model.trajectory(_flown(scenario, model, sc, dated_initial_state_lu(sc, scenario, model),
                                                   times_tu), times_tu)
    for st in scenario.ground_stations:
        out[st.name] = DatedStationTrajectory(st.latitude_deg, st.longitude_deg, st.altitude_m,
                                              scenario.ephemeris.epoch(), times_s)
    return out


def _dated_model(scenario: Scenario):
    from liaison_cli.scenario.dated import dated_model

    return dated_model(scenario)


# Each dynamics model's builder from a scenario (its descriptor: dynamics.registry).
def _crtbp_model(scenario: Scenario):
    gravity = scenario.moon_gravity
    return crtbp_model(MU, scenario.model_error.truth_acceleration_m_s2, gravity.degree if gravity else 0,
                       gravity.filter_degree_or_truth if gravity else None,
                       gravity is not None and gravity.filter_field == "j2")


MODEL_BUILDERS = {"crtbp": _crtbp_model,
                  "ephemeris": _dated_model}


def dynamics_model(scenario: Scenario):
    """The scenario's dynamics model (the Earth-Moon CRTBP, or the dated DE421 + SRP model), by its builder."""
    return MODEL_BUILDERS[scenario.dynamics](scenario)


def apply_station_priority(scenario: Scenario, visibility: list) -> list:
    """One ground observation per epoch and spacecraft (003): of the stations that see a spacecraft, only the
    first in priority keeps its link's epoch. The priority is station_priority, then the stations it does not
    name in ground_stations order (a partial list does not exempt the others). Without station_priority,
    and for links without a station, nothing changes."""
    if scenario.station_priority is None:
        return visibility
    out = list(visibility)
    unnamed = [st.name for st in scenario.ground_stations if st.name not in scenario.station_priority]
    rank = {name: r for r, name in enumerate([*scenario.station_priority, *unnamed])}
    by_target = {}
    for i, link in enumerate(scenario.links):
        station = next((end for end in (link.receiver, link.transponder) if end in rank), None)
        if station is not None:
            target = link.transponder if station == link.receiver else link.receiver
            by_target.setdefault(target, []).append((rank[station], i))
    for ranked in by_target.values():
        taken = np.zeros_like(out[0])
        for _, i in sorted(ranked):
            out[i] = out[i] & ~taken
            taken |= out[i]
    return out


def visible_epochs(scenario: Scenario, link, trajectories, model, times_s) -> np.ndarray:
    """(m,) True where the link can measure: every signal path (receiver - transponder, and a second
    receiver's) clears the elevation masks of its station ends and, with `occultation`, the Earth and Moon."""
    stations = {st.name: st for st in scenario.ground_stations}
    ends = [link.receiver] + ([link.second_receiver] if link.second_receiver is not None else [])
    visible = np.ones(len(times_s), dtype=bool)
    bodies = None
    for end in ends:
        path = (end, link.transponder)
        for station, other in (path, path[::-1]):
            if station in stations:
                track = trajectories[station]
                elevation = elevation_rad(track.states[:, 0:3], track.up, trajectories[other].states[:, 0:3])
                visible &= elevation >= np.radians(stations[station].elevation_mask_deg)
        if link.occultation:
            if bodies is None:
                bodies = model.body_positions_lu(times_s)
            visible &= not_occulted(trajectories[end].states[:, 0:3], trajectories[link.transponder].states[:, 0:3],
                                    **bodies, check_earth=not any(who in stations for who in path))
    return visible


def truth_and_measurements(scenario: Scenario, model: DynamicsModel, cache: dict | None = None):
    """times_s (m,), {name: trajectory}, noise-free measurements (m, C) with row 0 NaN. With `cache`, the
    trajectories are kept under a key without the links (another link set reuses them: 004's receiver
    pairs) and the measurements under one with them (a sweep over noise or filter settings)."""
    if cache is not None:
        key = truth_key(scenario)
        if key not in cache:
            flown_key = ("trajectories", trajectory_key(scenario))
            if flown_key not in cache:
                times = measurement_times_s(scenario)
                cache[flown_key] = (times, _trajectories(scenario, model, times, cache.get(SPACECRAFT_CACHE)))
            cache[key] = _measured(scenario, model, *cache[flown_key])
        return cache[key]
    times_s = measurement_times_s(scenario)
    return _measured(scenario, model, times_s, _trajectories(scenario, model, times_s))


def link_visibility(scenario: Scenario, model: DynamicsModel, times_s, trajectories) -> list:
    """Per link, (m,) True where it measures: elevation masks, occultation, then station_priority."""
    return apply_station_priority(scenario, [visible_epochs(scenario, link, trajectories, model, times_s)
                                        for link in scenario.links])


def participant_trajectories(scenario: Scenario, model: DynamicsModel, times_s) -> dict:
    """{participant name: trajectory (.states (m, 6), stations also .up)}: the truth of every participant."""
    return _trajectories(scenario, model, times_s)


def _measured(scenario: Scenario, model: DynamicsModel, times_s, trajectories):
    """(times_s, trajectories, noise-free measurements (m, C) with row 0 NaN) for the scenario's links."""
    visibility = link_visibility(scenario, model, times_s, trajectories)
    columns = []
    for link, visible in zip(scenario.links, visibility):
        receiver, transponder = trajectories[link.receiver], trajectories[link.transponder]
        second = [trajectories[link.second_receiver]] if link.second_receiver is not None else []
        for observable in link_observables(link):
            for channel in observable.channels:
                values = observable.simulate(channel.code, receiver, transponder, scenario.measurement.light_time,
                                             *second)
                columns.append(np.where(visible, values, np.nan))
    measurements = np.stack(columns, axis=1)
    measurements[0, :] = np.nan  # the filter starts at t0 with no measurement
    return times_s, trajectories, measurements


def burn_step(scenario: Scenario, manoeuvre) -> int:
    """The measurement epoch a manoeuvre follows (its index)."""
    return int(round(manoeuvre.epoch_days * SECONDS_PER_DAY / scenario.measurement.interval_s))
