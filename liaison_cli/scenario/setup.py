"""Scenario -> arrays: participants' truth, noise-free measurements, the filter's state layout and matrices.

Everything here is computed once per scenario and shared (read-only) by every Monte Carlo run. What is
drawn per run (initial error, noise, biases, clock histories) is described here and drawn by the worker.
"""

import json
from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.clock import clock_process_noise
from liaison_cli.dynamics.constants import LU_KM, M_PER_LU, M_S_PER_VU, MU, SECONDS_PER_DAY, TU_S
from liaison_cli.dynamics.ground_station import GroundStationTrajectory
from liaison_cli.dynamics.model import DynamicsModel, crtbp_model
from liaison_cli.dynamics.trajectory import states_with_accelerations
from liaison_cli.estimation.batch import JACOBIAN_EVERY, JACOBIAN_FIRST
from liaison_cli.estimation.blocks import BLOCK_CLOCK, BLOCK_CONSTANT, BLOCK_SPACECRAFT, StateBlock, StateLayout
from liaison_cli.estimation.estimators import BatchArrays, FilterArrays
from liaison_cli.estimation.initial_batch import InitialBatchSettings

# The initial batch's Gauss-Newton stops when no position correction exceeds this: far below any hand-over
# sigma, far above the round-off of a multi-day propagation.
INITIAL_BATCH_TOLERANCE_M = 0.1
from liaison_cli.estimation.process_noise import spacecraft_process_noise
from liaison_cli.measurements.observable import FLAG_ROTATING_FRAME
from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.measurements.visibility import elevation_rad, not_occulted
from liaison_cli.scenario.observed import observed_measurements
from liaison_cli.scenario.reference_states import initial_state_lu
from liaison_cli.scenario.schema import Scenario

SPEED_OF_LIGHT_M_S = 299792458.0
MAX_MODIFIERS = 3  # per channel: a link bias and the two ends' clocks


def per_axis_block_diagonal(n_sc: int, position_value: float, velocity_value: float) -> np.ndarray:
    """(6 n_sc, 6 n_sc) diagonal with the position value on position axes, velocity on velocity axes."""
    one = np.array([position_value] * 3 + [velocity_value] * 3)
    return np.diag(np.tile(one, n_sc))


@dataclass(frozen=True)
class Channel:
    """One scalar measurement channel: the link it belongs to, its kind and labels, its modifiers."""

    link: int
    link_label: str
    observable: str
    kind: int
    label: str
    unit: str
    scale_si: float
    takes_range_bias: bool
    clock_coefficients: tuple[float, float]
    measures_clock_offset: bool = False


@dataclass(frozen=True)
class ClockTruth:
    """A clock to simulate per run: its participant, its state offset in the filter (-1 when the estimator
    does not carry it), its model in SI (diffusions, deterministic drifts mu1 s/s and mu2 1/s), and the
    channels it enters (index, coefficient). Scale: seconds -> filter units (range and range-rate)."""

    owner: str
    state_start: int
    sigma1: float
    sigma2: float
    initial_sigma: tuple[float, float]
    scale: tuple[float, float]
    channels: tuple[tuple[int, float], ...]
    mu1: float = 0.0
    mu2: float = 0.0


@dataclass(frozen=True, eq=False)
class Problem:
    """Arrays of one scenario, in LU / TU unless a name says otherwise.

    times_s (m,); truth (m, 6 n_sc) of the estimated spacecraft; measurements_true (m, C) noise-free (row 0
    unused, NaN where a channel sees nothing); channels (C,) descriptions; filter: the estimator's arrays;
    bias_lu / bias_sigma_lu: constant and per-run random range bias of every link in the truth; clocks:
    the truth clocks to draw per run; initial_error_sigma (6 n_sc,) for the 'fixed_sigma' draw.
    """

    scenario: Scenario
    spacecraft: tuple[str, ...]
    link_labels: tuple[str, ...]
    link_ends: tuple[tuple[int, int], ...]  # (receiver, transponder) spacecraft indices, -1 for a known end
    times_s: np.ndarray
    truth: np.ndarray
    measurements_true: np.ndarray
    channels: tuple[Channel, ...]
    filter: FilterArrays
    sigma_m: float
    bias_lu: float
    bias_sigma_lu: float
    bias_state_start: int  # first link-bias state in the filter, -1 if the filter has none
    clocks: tuple[ClockTruth, ...]
    initial_error_sigma: np.ndarray
    dynamics: DynamicsModel
    manoeuvres: tuple = ()  # (Delta-v state start, true Delta-v (3,), a-priori sigma), scaled units
    observed: object = None  # measurements: {tdm: FILE}: scenario.observed.ObservedMeasurements, else None

    @property
    def n_spacecraft(self) -> int:
        return len(self.spacecraft)

    @property
    def n_steps(self) -> int:
        return self.times_s.shape[0]

    @property
    def n_bias(self) -> int:
        return len(self.link_labels) if self.bias_state_start >= 0 else 0

    @property
    def channel_scale_si(self) -> np.ndarray:
        """(C,) factors from filter units to m, m/s or rad."""
        return np.array([ch.scale_si for ch in self.channels])

    @property
    def channel_labels(self) -> list[tuple[str, str, str]]:
        """(link label, observable, unit) per channel."""
        return [(ch.link_label, ch.label, ch.unit) for ch in self.channels]

    @property
    def channel_link(self) -> np.ndarray:
        return np.array([ch.link for ch in self.channels], dtype=np.int64)

    # Short names for the arrays most callers need.
    P0 = property(lambda self: self.filter.P0)
    Q = property(lambda self: self.filter.Q)
    sigma_lu = property(lambda self: self.filter.sigma)
    dt_tu = property(lambda self: self.filter.dt_tu)
    substeps = property(lambda self: self.filter.substeps)
    mu = property(lambda self: float(self.dynamics.params[0]))
    link_receiver = property(lambda self: np.array([r for r, _ in self.link_ends], dtype=np.int64))
    link_transponder = property(lambda self: np.array([t for _, t in self.link_ends], dtype=np.int64))


def truth_key(scenario: Scenario) -> str:
    """The scenario fields that fix truth and noise-free measurements (not noise, filter or seed)."""
    return json.dumps({"trajectories": trajectory_key(scenario),
                       "links": [link.model_dump(mode="json") for link in scenario.links],
                       "station_priority": scenario.station_priority,
                       "light_time": scenario.measurement.light_time}, sort_keys=True)


def trajectory_key(scenario: Scenario) -> str:
    """The scenario fields that fix the participants' trajectories at the epochs (not the links)."""
    fields = {
        "spacecraft": [{"orbit": sc.orbit, "elements": sc.elements and sc.elements.model_dump(),
                        "period_days": sc.period_days, "amplitude_km": sc.amplitude_km, "role": sc.role,
                        "phase": sc.phase, "longitude_deg": sc.longitude_deg,
                        "departure": sc.departure and sc.departure.model_dump(),
                        "manoeuvre": sc.manoeuvre and sc.manoeuvre.model_dump()}
                       for sc in scenario.spacecraft],
        "ground_stations": [st.model_dump(mode="json") for st in scenario.ground_stations],
        "duration_days": scenario.epochs_end_days(),
        "interval_s": scenario.measurement.interval_s,
        "dynamics": scenario.dynamics,
        "ephemeris": scenario.ephemeris and scenario.ephemeris.model_dump(),
        "state_km": [sc.state_km for sc in scenario.spacecraft],
        "orbit_file": [sc.orbit_file and sc.orbit_file.model_dump() for sc in scenario.spacecraft],
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


GEOSTATIONARY_ALTITUDE_M = 35786.03e3  # radius 42,164.17 km above the WGS84 equator (sidereal-day orbit)


def _flown(scenario: Scenario, model, spacecraft, state0, times_tu) -> np.ndarray:
    """The truth (m, 6) from state0; a manoeuvre's Delta-v joins the velocity just after its epoch (the
    state at that epoch is the one before the burn)."""
    if spacecraft.manoeuvre is None:
        return model.truth_states(state0, times_tu)
    k = burn_step(scenario, spacecraft.manoeuvre)
    before = model.truth_states(state0, times_tu[: k + 1])
    kicked = before[-1].copy()
    kicked[3:] += np.array(spacecraft.manoeuvre.delta_v_m_s) / M_S_PER_VU
    after = model.truth_states(kicked, times_tu[k:])
    return np.vstack([before, after[1:]])


def _trajectories(scenario: Scenario, model: DynamicsModel, times_s):
    """{participant name: trajectory} for every spacecraft (truth propagation) and ground station."""
    times_tu = times_s / TU_S
    if scenario.dynamics == "ephemeris":
        from liaison_cli.scenario.dated import DatedStationTrajectory, dated_initial_state_lu

        out = {}
        for sc in scenario.spacecraft:
            if sc.longitude_deg is not None:  # station-kept geostationary: a point fixed to the rotating Earth
                out[sc.name] = DatedStationTrajectory(0.0, sc.longitude_deg, GEOSTATIONARY_ALTITUDE_M,
                                                      scenario.ephemeris.epoch(), times_s)
            elif sc.orbit_file is not None and sc.orbit_file.kind == "oem":  # the truth follows the file
                from liaison_cli.scenario.orbit_files import oem_truth_lu

                out[sc.name] = model.trajectory(oem_truth_lu(sc, model.epoch_tdb_s, times_s), times_tu)
            else:
                out[sc.name] = model.trajectory(_flown(scenario, model, sc, dated_initial_state_lu(sc, scenario, model),
                                                       times_tu), times_tu)
        for st in scenario.ground_stations:
            out[st.name] = DatedStationTrajectory(st.latitude_deg, st.longitude_deg, st.altitude_m,
                                                  scenario.ephemeris.epoch(), times_s)
        return out
    out = {sc.name: model.trajectory(_flown(scenario, model, sc, initial_state_lu(sc), times_tu))
           for sc in scenario.spacecraft}
    for st in scenario.ground_stations:
        out[st.name] = GroundStationTrajectory(st.latitude_deg, st.longitude_deg, st.altitude_m, times_tu)
    return out


def dynamics_model(scenario: Scenario):
    """The scenario's dynamics: the Earth-Moon CRTBP, or the dated DE421 + SRP model."""
    if scenario.dynamics == "ephemeris":
        from liaison_cli.scenario.dated import dated_model

        return dated_model(scenario)
    return crtbp_model(MU)


def _station_priority(scenario: Scenario, visibility: list) -> list:
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


def _visible(scenario: Scenario, link, trajectories, model, times_s) -> np.ndarray:
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


def _truth_and_measurements(scenario: Scenario, model: DynamicsModel, cache: dict | None = None):
    """times_s (m,), {name: trajectory}, noise-free measurements (m, C) with row 0 NaN. With `cache`, the
    trajectories are kept under a key without the links (another link set reuses them: 004's receiver
    pairs) and the measurements under one with them (a sweep over noise or filter settings)."""
    if cache is not None:
        key = truth_key(scenario)
        if key not in cache:
            flown_key = ("trajectories", trajectory_key(scenario))
            if flown_key not in cache:
                times = measurement_times_s(scenario)
                cache[flown_key] = (times, _trajectories(scenario, model, times))
            cache[key] = _measured(scenario, model, *cache[flown_key])
        return cache[key]
    times_s = measurement_times_s(scenario)
    return _measured(scenario, model, times_s, _trajectories(scenario, model, times_s))


def link_visibility(scenario: Scenario, model: DynamicsModel, times_s, trajectories) -> list:
    """Per link, (m,) True where it measures: elevation masks, occultation, then station_priority."""
    return _station_priority(scenario, [_visible(scenario, link, trajectories, model, times_s)
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


def _channels(scenario: Scenario) -> list[Channel]:
    out = []
    for index, link in enumerate(scenario.links):
        for observable in link_observables(link):
            for position, kind in enumerate(observable.channels):
                out.append(Channel(index, f"{link.receiver}->{link.transponder}", observable.name, kind.code,
                                   kind.label, kind.unit, kind.scale_si, observable.takes_range_bias,
                                   observable.channel_clock_coefficients(position),
                                   position == observable.clock_offset_channel))
    return out


def _layout(scenario: Scenario) -> StateLayout:
    """Spacecraft blocks, then clocks, then link biases (estimated, or considered last)."""
    blocks = [StateBlock(BLOCK_SPACECRAFT, 6, name) for name in scenario.spacecraft_names()]
    if scenario.estimator != "batch":  # the batch solves for orbits; clocks are synchronised by clock_sync
        blocks += [StateBlock(BLOCK_CLOCK, 2, sc.name) for sc in scenario.spacecraft
                   if sc.role == "estimated" and sc.clock is not None]
    blocks += [StateBlock(BLOCK_CONSTANT, 3, f"dv {sc.name}") for sc in scenario.spacecraft if sc.manoeuvre]
    if scenario.filter.bias != "ignore":
        consider = scenario.filter.bias == "consider"
        blocks += [StateBlock(BLOCK_CONSTANT, 1, f"bias {i}", consider) for i in range(len(scenario.links))]
    return StateLayout(tuple(blocks))


def burn_step(scenario: Scenario, manoeuvre) -> int:
    """The measurement epoch a manoeuvre follows (its index)."""
    return int(round(manoeuvre.epoch_days * SECONDS_PER_DAY / scenario.measurement.interval_s))


def _manoeuvres(scenario: Scenario, layout: StateLayout):
    """burns (N, 3) for filter_loop.apply_burns, and per burn (Delta-v start, true Delta-v (3,) and its
    a-priori sigma, scaled units) for the truth columns and the initial draw."""
    burns, truths = [], []
    for sc in scenario.spacecraft:
        if sc.manoeuvre is None:
            continue
        start = layout.start_of(BLOCK_CONSTANT, f"dv {sc.name}")
        burns.append((start, layout.start_of(BLOCK_SPACECRAFT, sc.name), burn_step(scenario, sc.manoeuvre)))
        truths.append((start, np.array(sc.manoeuvre.delta_v_m_s) / M_S_PER_VU, sc.manoeuvre.apriori_sigma_m_s / M_S_PER_VU))
    return np.array(burns, dtype=np.int64).reshape(-1, 3), tuple(truths)


def _clock_scale() -> np.ndarray:
    """Seconds -> LU for the phase, s/s -> LU/TU for the frequency (the filter keeps clocks in range units)."""
    return np.array([SPEED_OF_LIGHT_M_S / M_PER_LU, SPEED_OF_LIGHT_M_S / M_S_PER_VU])


def _apriori_sigmas(spacecraft, position_m: float, velocity_m_s: float) -> tuple[float, float]:
    """A spacecraft's own a-priori sigmas where it gives them, else the scenario-wide ones."""
    own_r, own_v = spacecraft.apriori_sigma_position_m, spacecraft.apriori_sigma_velocity_m_s
    return (position_m if own_r is None else own_r), (velocity_m_s if own_v is None else own_v)


def _initial_error_sigma(scenario: Scenario) -> np.ndarray:
    """(6 n_sc,) per-axis sigmas of the fixed_sigma initial error, scaled units."""
    ie = scenario.initial_error
    by_name = {sc.name: sc for sc in scenario.spacecraft}
    out = []
    for name in scenario.spacecraft_names():
        sigma_r, sigma_v = _apriori_sigmas(by_name[name], ie.sigma_position_m, ie.sigma_velocity_m_s)
        out += [sigma_r / M_PER_LU] * 3 + [sigma_v / M_S_PER_VU] * 3
    return np.array(out)


def _matrices(scenario: Scenario, layout: StateLayout):
    """P0 and Q (n, n), block by block."""
    n = layout.n
    P0, Q = np.zeros((n, n)), np.zeros((n, n))
    flt = scenario.filter
    interval_s = scenario.measurement.interval_s
    by_name = {sc.name: sc for sc in scenario.spacecraft}
    for block, a in zip(layout.blocks, layout.starts):
        s = slice(a, a + block.size)
        if block.kind == BLOCK_SPACECRAFT:
            sigma_r, sigma_v = _apriori_sigmas(by_name[block.owner], flt.initial_sigma_position_m,
                                               flt.initial_sigma_velocity_m_s)
            P0[s, s] = per_axis_block_diagonal(1, (sigma_r / M_PER_LU) ** 2, (sigma_v / M_S_PER_VU) ** 2)
            # State-noise compensation (estimation.process_noise): white acceleration sigma_a.
            own = by_name[block.owner].process_noise_accel_m_s2
            sigma_a = flt.process_noise_accel_m_s2 if own is None else own
            Q[s, s] = spacecraft_process_noise(sigma_a, interval_s, flt.process_noise_model, M_PER_LU, M_S_PER_VU)
        elif block.kind == BLOCK_CLOCK:
            clock = by_name[block.owner].clock
            scale = _clock_scale()
            P0[s, s] = np.diag((np.array([clock.initial_offset_sigma_s, clock.initial_frequency_sigma]) * scale) ** 2)
            Q[s, s] = clock_process_noise(interval_s, clock.sigma1, clock.sigma2) * np.outer(
                scale, scale)
        elif block.owner.startswith("dv "):
            sigma_lu = by_name[block.owner[3:]].manoeuvre.apriori_sigma_m_s / M_S_PER_VU
            P0[s, s] = np.eye(3) * sigma_lu**2
        else:
            P0[s, s] = (flt.bias_apriori_sigma_m / M_PER_LU) ** 2
    return P0, Q


def _channel_tables(scenario: Scenario, channels, layout: StateLayout, index_of_known):
    """channel_ends (C, 6), channel_flags (C,), channel_mod_index / _coeff (C, MAX_MODIFIERS)."""
    n_channels = len(channels)
    ends = np.full((n_channels, 6), -1, dtype=np.int64)
    flags = np.zeros(n_channels, dtype=np.int64)
    mod_index = np.full((n_channels, MAX_MODIFIERS), -1, dtype=np.int64)
    mod_coeff = np.zeros((n_channels, MAX_MODIFIERS))
    bias_start = layout.start_of(BLOCK_CONSTANT, "bias 0")
    for c, ch in enumerate(channels):
        link = scenario.links[ch.link]
        for column, who in ((0, link.receiver), (2, link.transponder), (4, link.second_receiver)):
            if who is None:
                continue
            state = layout.start_of(BLOCK_SPACECRAFT, who)
            ends[c, column] = state
            ends[c, column + 1] = -1 if state >= 0 else index_of_known[who]
        flags[c] = OBSERVABLES[ch.observable].filter_flags(scenario.filter)
        mods = []
        if ch.takes_range_bias and bias_start >= 0:
            mods.append((bias_start + ch.link, 1.0))
        for who, coeff in zip((link.receiver, link.transponder), ch.clock_coefficients):
            clock = layout.start_of(BLOCK_CLOCK, who)
            if coeff != 0.0 and clock >= 0:
                mods.append((clock, coeff))
        for j, (index, coeff) in enumerate(mods):
            mod_index[c, j], mod_coeff[c, j] = index, coeff
    return ends, flags, mod_index, mod_coeff


def _channel_sigmas(scenario: Scenario, channels) -> np.ndarray:
    sigmas, done = [], set()
    for ch in channels:
        if (ch.link, ch.observable) in done:
            continue
        done.add((ch.link, ch.observable))
        link = scenario.links[ch.link]
        receiver = scenario.participant(link.receiver)
        noise = link.noise.applied_to(scenario.noise) if link.noise is not None else scenario.noise
        sigmas += OBSERVABLES[ch.observable].sigma(noise, receiver)
    return np.array(sigmas)


def _clock_truths(scenario: Scenario, channels, layout: StateLayout) -> tuple[ClockTruth, ...]:
    """Every clock that enters a channel (or the filter): simulated per run."""
    out = []
    for sc in scenario.spacecraft:
        if sc.clock is None:
            continue
        start = layout.start_of(BLOCK_CLOCK, sc.name)
        entries = []
        for c, ch in enumerate(channels):
            link = scenario.links[ch.link]
            for who, coeff in zip((link.receiver, link.transponder), ch.clock_coefficients):
                if who == sc.name and coeff != 0.0:
                    entries.append((c, coeff))
        if start < 0 and not entries:
            continue
        clock = sc.clock
        out.append(ClockTruth(sc.name, start, clock.sigma1, clock.sigma2,
                              (clock.initial_offset_sigma_s, clock.initial_frequency_sigma),
                              tuple(_clock_scale()), tuple(entries), clock.mu1, clock.mu2))
    return tuple(out)


def _batch_arrays(scenario: Scenario, model: DynamicsModel, times_s, trajectories) -> BatchArrays | None:
    """RK8 steps per interval along the estimated spacecraft's nominal paths, and the span's epoch count."""
    spec = scenario.batch
    if spec is None:
        return None
    positions = np.stack([trajectories[name].states[:, 0:3] for name in scenario.spacecraft_names()], axis=1)
    counts = model.rk8_step_counts(positions, scenario.measurement.interval_s / TU_S)
    interval_s = scenario.measurement.interval_s
    n_use = int(np.floor(spec.span_days * SECONDS_PER_DAY / interval_s + 1e-9)) + 1
    n_predict = int(np.floor(spec.prediction_hours * 3600.0 / interval_s + 1e-9))
    renewal = int(round((spec.renewal_hours or 0.0) * 3600.0 / interval_s))
    return BatchArrays(counts=counts, n_use=n_use, use_apriori=spec.apriori, max_iterations=spec.max_iterations,
                       tolerance_lu=spec.tolerance_m / M_PER_LU,
                       jacobian=JACOBIAN_EVERY if spec.jacobian == "every_iteration" else JACOBIAN_FIRST,
                       n_predict=n_predict, windows=spec.windows, renewal_steps=renewal)


def _initial_batch(scenario: Scenario) -> InitialBatchSettings | None:
    """filter.initial_batch_*: the windows as epoch counts (estimation.initial_batch)."""
    flt = scenario.filter
    if flt.initial_batch_hours is None:
        return None
    interval_s = scenario.measurement.interval_s

    def epochs(hours):
        return int(round(hours * 3600.0 / interval_s)) + 1

    return InitialBatchSettings(first_window=epochs(flt.initial_batch_hours),
                                max_window=epochs(flt.initial_batch_max_hours or flt.initial_batch_hours),
                                handover_sigma_lu=flt.initial_batch_handover_sigma_km / LU_KM,
                                max_iterations=flt.initial_batch_max_iterations,
                                tolerance_lu=INITIAL_BATCH_TOLERANCE_M / M_PER_LU)


def prepare_problem(scenario: Scenario, truth_cache: dict | None = None) -> Problem:
    """Build the arrays of a scenario. Pass the same `truth_cache` dict to a series of scenarios that
    differ only in noise / filter / seed (a sweep over sigma) and the truth is propagated once."""
    model = dynamics_model(scenario)
    times_s, trajectories, measurements = _truth_and_measurements(scenario, model, truth_cache)

    names = scenario.spacecraft_names()
    known = [sc.name for sc in scenario.spacecraft if sc.role == "known"] + [st.name for st in scenario.ground_stations]
    index_of_known = {name: i for i, name in enumerate(known)}
    # A three-end light-time channel moves known ends over the light time: their rows carry accelerations.
    with_accelerations = any(OBSERVABLES[o].end_accelerations for link in scenario.links for o in link.observables)
    known_states = np.zeros((len(times_s), len(known), 9 if with_accelerations else 6))
    for name, i in index_of_known.items():
        trajectory = trajectories[name]
        known_states[:, i] = states_with_accelerations(trajectory) if with_accelerations else trajectory.states
    layout = _layout(scenario)
    burns, manoeuvres = _manoeuvres(scenario, layout)
    channels = _channels(scenario)
    P0, Q = _matrices(scenario, layout)
    ends, flags, mod_index, mod_coeff = _channel_tables(scenario, channels, layout, index_of_known)
    if model.rotating_frame:
        flags |= FLAG_ROTATING_FRAME
    flt = scenario.filter
    arrays = FilterArrays(
        layout=layout, P0=P0, Q=Q, known_states=known_states,
        channel_kind=np.array([ch.kind for ch in channels], dtype=np.int64), channel_ends=ends,
        channel_flags=flags, channel_mod_index=mod_index, channel_mod_coeff=mod_coeff,
        sigma=_channel_sigmas(scenario, channels), model=model.code, model_params=model.filter_params,
        dt_tu=scenario.measurement.interval_s / TU_S, substeps=flt.rk4_substeps,
        divergence_position_lu=flt.divergence_position_km / LU_KM, underweight=flt.underweighting, burns=burns,
        residual_gate_sigma=flt.residual_gate_sigma or 0.0, residual_gate_after=flt.residual_gate_after,
        smoother=flt.smoother == "rts",
        batch=_batch_arrays(scenario, model, times_s, trajectories),
        initial_batch=_initial_batch(scenario),
    )
    sc_index = {name: i for i, name in enumerate(names)}
    return Problem(
        scenario=scenario,
        spacecraft=tuple(names),
        link_labels=tuple(f"{link.receiver}->{link.transponder}" for link in scenario.links),
        link_ends=tuple((sc_index.get(link.receiver, -1), sc_index.get(link.transponder, -1))
                        for link in scenario.links),
        times_s=times_s,
        truth=np.ascontiguousarray(np.hstack([trajectories[name].states for name in names])),
        measurements_true=np.ascontiguousarray(measurements),
        channels=tuple(channels),
        filter=arrays,
        sigma_m=scenario.noise.resolved_sigma_m(),
        bias_lu=scenario.noise.resolved_bias_m() / M_PER_LU,
        bias_sigma_lu=scenario.noise.bias_sigma_m / M_PER_LU,
        bias_state_start=layout.start_of(BLOCK_CONSTANT, "bias 0"),
        clocks=_clock_truths(scenario, channels, layout),
        initial_error_sigma=_initial_error_sigma(scenario),
        dynamics=model,
        manoeuvres=manoeuvres,
        observed=observed_measurements(scenario, channels, times_s, model),
    )
