"""Scenario -> the estimator's arrays: the state layout (spacecraft, clocks, Delta-v, link biases), P0 and Q,
the measurement channels and their tables (ends, flags, bias and clock modifiers, sigmas), the batch's
settings, and what each run draws (the truth clocks, the initial-error sigmas)."""

from dataclasses import dataclass

import numpy as np

from liaison_cli.analysis.ric import primaries_lu, primary_velocities_lu
from liaison_cli.dynamics.clock import clock_process_noise
from liaison_cli.dynamics.constants import (LU_KM, M_PER_LU, M_S2_PER_AU, M_S_PER_VU, SECONDS_PER_DAY,
                                           SPEED_OF_LIGHT_M_S, TU_S)
from liaison_cli.dynamics.model import DynamicsModel
from liaison_cli.dynamics.trajectory import states_with_accelerations
from liaison_cli.estimation.batch import JACOBIAN_EVERY, JACOBIAN_FIRST
from liaison_cli.estimation.blocks import (BLOCK_CLOCK, BLOCK_CONSTANT, BLOCK_EMPIRICAL, BLOCK_PARAMETER,
                                          BLOCK_SPACECRAFT, FORMATION, ROLE_EMPIRICAL, ROLE_LINK_BIAS, ROLE_MANOEUVRE,
                                          StateBlock, StateLayout, owner_name)
from liaison_cli.estimation.estimators import BatchArrays, FilterArrays
from liaison_cli.estimation.filter_loop import (END_RECEIVER_KNOWN, END_RECEIVER_STATE, END_SECOND_KNOWN,
                                                END_SECOND_STATE, END_TRANSMITTER_KNOWN, END_TRANSMITTER_STATE)
from liaison_cli.estimation.initial_batch import InitialBatchSettings
from liaison_cli.estimation.process_noise import (coupled_process_noise, gauss_markov_process_noise,
                                                 psd_process_noise, spacecraft_process_noise)
from liaison_cli.measurements.observable import FLAG_ROTATING_FRAME
from liaison_cli.measurements.registry import OBSERVABLES
from liaison_cli.scenario.estimation_settings import PROCESS_NOISE_PSD, PROCESS_NOISE_PSD_RIC, PROCESS_NOISE_SIGMA_A
from liaison_cli.scenario.default_noise import (default_psd, field_truncation_psd, linked_spacecraft,
                                                 with_field_coupling)
from liaison_cli.scenario.integration_steps import step_choices, substeps_per_block
from liaison_cli.scenario.links import link_label
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.scenario.truth import burn_step, link_observables

# The initial batch's Gauss-Newton stops when no position correction exceeds this: far below any hand-over
# sigma, far above the round-off of a multi-day propagation.
INITIAL_BATCH_TOLERANCE_M = 0.1


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


def _channels(scenario: Scenario) -> list[Channel]:
    out = []
    for index, link in enumerate(scenario.links):
        for observable in link_observables(link):
            for position, kind in enumerate(observable.channels):
                out.append(Channel(index, link_label(link), observable.name, kind.code,
                                   kind.label, kind.unit, kind.scale_si, observable.takes_range_bias,
                                   observable.channel_clock_coefficients(position),
                                   position == observable.clock_offset_channel))
    return out


def state_layout(scenario: Scenario) -> StateLayout:
    """Spacecraft blocks, then clocks, Delta-v, dynamics parameters (one per filter.estimated_parameters name,
    shared by the formation), link biases when estimated, empirical accelerations (one per spacecraft,
    filter.empirical_acceleration), and link biases when considered (consider blocks last)."""
    estimator = scenario.estimator_descriptor()
    blocks = [StateBlock(BLOCK_SPACECRAFT, 6, name) for name in scenario.spacecraft_names()]
    if estimator.carries_clocks:  # else clocks are synchronised apart from the estimator, by clock_sync
        blocks += [StateBlock(BLOCK_CLOCK, 2, sc.name) for sc in scenario.spacecraft
                   if sc.role == "estimated" and sc.clock is not None]
    if estimator.carries_manoeuvres:
        blocks += [StateBlock(BLOCK_CONSTANT, 3, owner_name(ROLE_MANOEUVRE, sc.name)) for sc in scenario.spacecraft
                   if sc.manoeuvre]
    # One state per parameter for the formation: the dated model has one C_R A/m for every spacecraft, and
    # model_error draws one error per run (a state per spacecraft would start the filter on independent
    # errors where the truth has one: measured 54 % of eph_eml1_eml2_dsn's NEES in band against 90 %+ own).
    blocks += [StateBlock(BLOCK_PARAMETER, 1, owner_name(parameter, FORMATION))
               for parameter in scenario.filter.estimated_parameters]
    empirical = [StateBlock(BLOCK_EMPIRICAL, 3, owner_name(ROLE_EMPIRICAL, name))
                 for name in scenario.spacecraft_names()] if scenario.filter.empirical_acceleration is not None else []
    biases, consider = [], scenario.filter.bias == "consider"
    if scenario.filter.bias != "ignore" and estimator.carries_biases:
        biases = [StateBlock(BLOCK_CONSTANT, 1, owner_name(ROLE_LINK_BIAS, i), consider)
                  for i in range(len(scenario.links))]
    # The empirical accelerations last among the estimated blocks (StateLayout.n_nees), consider biases after.
    return StateLayout(tuple(blocks + (empirical + biases if consider else biases + empirical)))


def _manoeuvres(scenario: Scenario, layout: StateLayout):
    """burns (N, 3) for filter_loop.apply_burns, and per burn (Delta-v start, true Delta-v (3,) and its
    a-priori sigma, scaled units) for the truth columns and the initial draw."""
    burns, truths = [], []
    for sc in scenario.spacecraft:
        if sc.manoeuvre is None:
            continue
        start = layout.start_of(BLOCK_CONSTANT, owner_name(ROLE_MANOEUVRE, sc.name))
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


def initial_error_sigma(scenario: Scenario) -> np.ndarray:
    """(6 n_sc,) per-axis sigmas of the fixed_sigma initial error, scaled units."""
    ie = scenario.initial_error
    by_name = {sc.name: sc for sc in scenario.spacecraft}
    out = []
    for name in scenario.spacecraft_names():
        sigma_r, sigma_v = _apriori_sigmas(by_name[name], ie.sigma_position_m, ie.sigma_velocity_m_s)
        out += [sigma_r / M_PER_LU] * 3 + [sigma_v / M_S_PER_VU] * 3
    return np.array(out)


def biased_filter_params(scenario: Scenario, model, cr_draw: float = 0.0, moon_gm_draw: float = 0.0):
    """The filter's dynamics parameters with model_error's fixed errors, times 1 + a run's drawn ones (the draws
    are the fractions cr_sigma N and moon_gm_sigma N; 0: none): scenario.model_error."""
    error = scenario.model_error
    cr_factor = (1.0 + error.cr_bias) * (1.0 + cr_draw)
    gm_factor = (1.0 + error.moon_gm_bias) * (1.0 + moon_gm_draw)
    if cr_factor == 1.0 and gm_factor == 1.0:
        return model.filter_params
    return model.scaled_filter_params(cr_factor, gm_factor)


def process_noise_matrix(scenario: Scenario, layout: StateLayout, defaults: dict) -> np.ndarray:
    """Q (n, n) with these defaults {spacecraft: DefaultNoise} for the spacecraft that name no process noise (what
    estimator_setup built, with other defaults: campaign.engine.noise_check raises some)."""
    return _matrices(scenario, layout, defaults)[1]


def _matrices(scenario: Scenario, layout: StateLayout, defaults: dict):
    """P0 and Q (n, n), block by block; defaults: {spacecraft: DefaultNoise} for those that name no process
    noise (scenario.default_noise)."""
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
            # State-noise compensation (estimation.process_noise): a PSD, or the papers' per-step sigma_a.
            # A PSD per RIC axis is added at each step in the frame of the moment (_ric_noise).
            convention, value = flt.process_noise_of(by_name[block.owner])
            if value is None:  # the derived default; none for an estimator without process noise (the batch)
                value = defaults[block.owner].psd_m2_s3 if block.owner in defaults else 0.0
            if convention == PROCESS_NOISE_PSD:
                Q[s, s] = psd_process_noise(value, interval_s, M_PER_LU, M_S_PER_VU)
            elif convention == PROCESS_NOISE_SIGMA_A:
                Q[s, s] = spacecraft_process_noise(value, interval_s, flt.process_noise_model, M_PER_LU, M_S_PER_VU)
        elif block.kind == BLOCK_CLOCK:
            clock = by_name[block.owner].clock
            scale = _clock_scale()
            P0[s, s] = np.diag((np.array([clock.initial_offset_sigma_s, clock.initial_frequency_sigma]) * scale) ** 2)
            Q[s, s] = clock_process_noise(interval_s, clock.sigma1, clock.sigma2) * np.outer(
                scale, scale)
        elif block.kind == BLOCK_PARAMETER:  # no process noise: ekf.predict_covariance_into relies on it
            role, _ = block.owner.split(" ", 1)
            P0[s, s] = flt.estimated_parameters[role] ** 2
        elif block.kind == BLOCK_EMPIRICAL:
            _empirical_matrices(scenario, layout, block, a, P0, Q)
        elif block.owner.startswith(owner_name(ROLE_MANOEUVRE, "")):
            sigma_lu = by_name[block.owner.split(" ", 1)[1]].manoeuvre.apriori_sigma_m_s / M_S_PER_VU
            P0[s, s] = np.eye(3) * sigma_lu**2
        else:
            P0[s, s] = (flt.bias_apriori_sigma_m / M_PER_LU) ** 2
    if flt.empirical_acceleration is not None:  # the form of Q the coupled covariance step takes
        Q = coupled_process_noise(Q, layout.empirical_couplings(), flt.empirical_acceleration.time_constant_s / TU_S,
                                  interval_s / TU_S)
    return P0, Q


def _ric_noise(scenario: Scenario, layout: StateLayout, model: DynamicsModel, times_s):
    """(ric (B, 3, 3), primaries (m, 2, 6)) for the spacecraft whose process noise is a PSD per RIC axis
    (kernel_args.ProcessNoise: per block and axis q [dt^3/3, dt^2/2, dt] in the state's units; the Earth's and
    the Moon's positions and velocities per epoch, analysis.ric's), or (None, None) when none is."""
    flt, by_name = scenario.filter, {sc.name: sc for sc in scenario.spacecraft}
    if not flt.uses_ric_process_noise(scenario.spacecraft):
        return None, None
    dt = scenario.measurement.interval_s
    ric = np.zeros((len(layout.blocks), 3, 3))
    for b, block in enumerate(layout.blocks):
        if block.kind == BLOCK_SPACECRAFT:
            convention, densities = flt.process_noise_of(by_name[block.owner])
            if convention == PROCESS_NOISE_PSD_RIC:
                for axis, q in enumerate(densities):  # the isotropic PSD's position, cross and velocity terms
                    block = psd_process_noise(q, dt, M_PER_LU, M_S_PER_VU)
                    ric[b, axis] = [block[0, 0], block[0, 3], block[3, 3]]
    positions = primaries_lu(float(model.params[0]), model.body_positions_lu(times_s), times_s)
    step_s = float(times_s[1] - times_s[0]) if len(times_s) > 1 else 1.0
    return ric, np.concatenate([positions, primary_velocities_lu(positions, step_s)], axis=2)


def _empirical_matrices(scenario: Scenario, layout: StateLayout, block, a: int, P0, Q) -> None:
    """An empirical-acceleration block at a: its a priori (its steady-state sigma) into P0, and the Gauss-Markov
    process noise of [its spacecraft's position and velocity, itself] added into Q (estimation.process_noise)."""
    spec = scenario.filter.empirical_acceleration
    P0[a : a + 3, a : a + 3] = np.eye(3) * (spec.sigma_m_s2 / M_S2_PER_AU) ** 2
    noise = gauss_markov_process_noise(spec.sigma_m_s2, spec.time_constant_s, scenario.measurement.interval_s,
                                       M_PER_LU, M_S_PER_VU)
    rows = np.r_[layout.start_of(BLOCK_SPACECRAFT, block.owner.split(" ", 1)[1]) + np.arange(6), a + np.arange(3)]
    Q[np.ix_(rows, rows)] += noise


def _channel_tables(scenario: Scenario, channels, layout: StateLayout, index_of_known):
    """channel_ends (C, 6), channel_flags (C,), channel_mod_index / _coeff (C, MAX_MODIFIERS)."""
    n_channels = len(channels)
    ends = np.full((n_channels, 6), -1, dtype=np.int64)
    flags = np.zeros(n_channels, dtype=np.int64)
    mod_index = np.full((n_channels, MAX_MODIFIERS), -1, dtype=np.int64)
    mod_coeff = np.zeros((n_channels, MAX_MODIFIERS))
    bias_start = layout.start_of(BLOCK_CONSTANT, owner_name(ROLE_LINK_BIAS, 0))
    matched = scenario.filter.model_copy(update={"range_model": scenario.filter_range_model()})
    for c, ch in enumerate(channels):
        link = scenario.links[ch.link]
        for state_column, known_column, who in ((END_RECEIVER_STATE, END_RECEIVER_KNOWN, link.receiver),
                                                (END_TRANSMITTER_STATE, END_TRANSMITTER_KNOWN, link.transponder),
                                                (END_SECOND_STATE, END_SECOND_KNOWN, link.second_receiver)):
            if who is None:
                continue
            state = layout.start_of(BLOCK_SPACECRAFT, who)
            ends[c, state_column] = state
            ends[c, known_column] = -1 if state >= 0 else index_of_known[who]
        flags[c] = OBSERVABLES[ch.observable].filter_flags(matched)
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


def clock_truths(scenario: Scenario, channels, layout: StateLayout) -> tuple[ClockTruth, ...]:
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


def known_participant_states(scenario: Scenario, times_s, trajectories) -> tuple[np.ndarray, dict]:
    """The filter's given states of known spacecraft and ground stations (m, K, 6 or 9) and each one's
    index. A three-end light-time channel moves known ends over the light time: their rows carry
    accelerations."""
    known = [sc.name for sc in scenario.spacecraft if sc.role == "known"] + [st.name for st in scenario.ground_stations]
    index_of_known = {name: i for i, name in enumerate(known)}
    with_accelerations = any(OBSERVABLES[o].end_accelerations for link in scenario.links for o in link.observables)
    known_states = np.zeros((len(times_s), len(known), 9 if with_accelerations else 6))
    for name, i in index_of_known.items():
        trajectory = trajectories[name]
        known_states[:, i] = states_with_accelerations(trajectory) if with_accelerations else trajectory.states
    return known_states, index_of_known


@dataclass(frozen=True, eq=False)
class EstimatorSetup:
    """What prepare_problem takes from here: the estimator's arrays, the layout and channels they are built
    on, and the manoeuvres' truth (Delta-v start, true Delta-v (3,), a-priori sigma, scaled units)."""

    arrays: FilterArrays
    layout: StateLayout
    channels: tuple[Channel, ...]
    manoeuvres: tuple
    step_choices: dict  # {estimated spacecraft: dynamics.step_choice.StepChoice}
    default_noises: dict  # {estimated spacecraft naming no process noise: scenario.default_noise.DefaultNoise}


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


def estimator_setup(scenario: Scenario, model: DynamicsModel, times_s, trajectories) -> EstimatorSetup:
    """The estimator's arrays of a scenario, along the truth's trajectories (the known participants' given
    states, the batch's RK8 step counts)."""
    known_states, index_of_known = known_participant_states(scenario, times_s, trajectories)
    layout = state_layout(scenario)
    burns, manoeuvres = _manoeuvres(scenario, layout)
    channels = _channels(scenario)
    defaults = default_noises(scenario, model, times_s, trajectories)
    P0, Q = _matrices(scenario, layout, defaults)
    ric_noise, primaries = _ric_noise(scenario, layout, model, times_s)
    ends, flags, mod_index, mod_coeff = _channel_tables(scenario, channels, layout, index_of_known)
    if model.rotating_frame:
        flags |= FLAG_ROTATING_FRAME
    flt = scenario.filter
    dt_tu = scenario.measurement.interval_s / TU_S
    choices = step_choices(scenario, model, dt_tu, trajectories)
    arrays = FilterArrays(
        layout=layout, P0=P0, Q=Q, known_states=known_states,
        channel_kind=np.array([ch.kind for ch in channels], dtype=np.int64), channel_ends=ends,
        channel_flags=flags, channel_mod_index=mod_index, channel_mod_coeff=mod_coeff,
        sigma=_channel_sigmas(scenario, channels), model=model.code, model_params=biased_filter_params(scenario, model),
        dt_tu=dt_tu, substeps=substeps_per_block(layout, choices),
        divergence_position_lu=flt.divergence_position_km / LU_KM, underweight=flt.underweighting, burns=burns,
        residual_gate_sigma=flt.residual_gate_sigma or 0.0, residual_gate_after=flt.residual_gate_after,
        smoother=flt.smoother == "rts",
        batch=_batch_arrays(scenario, model, times_s, trajectories),
        initial_batch=_initial_batch(scenario),
        empirical_tau_tu=(flt.empirical_acceleration.time_constant_s / TU_S
                          if flt.empirical_acceleration is not None else 0.0),
        ric_noise=ric_noise, primaries=primaries,
    )
    return EstimatorSetup(arrays, layout, tuple(channels), manoeuvres, choices, defaults)


def default_noises(scenario: Scenario, model: DynamicsModel, times_s, trajectories) -> dict:
    """{estimated spacecraft that names no process noise: its derived default} (scenario.default_noise); none for
    an estimator without process noise (the batch)."""
    if not scenario.estimator_descriptor().process_noise:
        return {}
    estimated = [sc for sc in scenario.spacecraft if sc.role == "estimated"]
    defaulted = [sc.name for sc in estimated if scenario.filter.process_noise_of(sc)[1] is None]
    if not defaulted:
        return {}
    # every estimated spacecraft's omitted field: a spacecraft that names its own noise still passes its share on
    field = {sc.name: field_truncation_psd(scenario, model, trajectories[sc.name].states, times_s) for sc in estimated}
    defaults = {name: default_psd(scenario, model, trajectories[name].states, times_s, field[name])
                for name in defaulted}
    return with_field_coupling(defaults, field, linked_spacecraft(scenario))
