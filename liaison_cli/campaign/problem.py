"""Scenario -> arrays: truth trajectories, noise-free measurements, filter matrices.

Everything here is computed once per scenario and shared (read-only) by every Monte Carlo run.
"""

import json
from dataclasses import dataclass

import numpy as np

from liaison_cli.campaign.schema import KEPLERIAN_ORBIT, Scenario
from liaison_cli.dynamics.constants import LU_KM, M_PER_LU, M_S_PER_VU, MU, SECONDS_PER_DAY, TU_S
from liaison_cli.dynamics.propagation import propagate_states
from liaison_cli.estimation.filter_loop import KIND_AZIMUTH, KIND_ELEVATION, KIND_RANGE, KIND_RANGE_RATE
from liaison_cli.measurements.los import azimuth_elevation, los_sigma_rad
from liaison_cli.measurements.range import TwoWayRange
from liaison_cli.measurements.range_rate import range_rate
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.orbits.keplerian import lunar_orbiter_state_lu


def initial_state_lu(spec) -> np.ndarray:
    if spec.period_days is not None:
        from liaison_cli.campaign.family_store import member_state

        return np.array(member_state(spec.orbit, float(spec.period_days)).state)
    if spec.amplitude_km is not None:
        from liaison_cli.campaign.family_store import member_by_amplitude_km

        return np.array(member_by_amplitude_km(spec.orbit, float(spec.amplitude_km)).state)
    if spec.orbit == KEPLERIAN_ORBIT:
        el = spec.elements
        return lunar_orbiter_state_lu(el.a_km, el.e, el.i_deg, el.raan_deg, el.argp_deg, el.ta_deg)
    return CATALOG[spec.orbit].state()


def per_axis_block_diagonal(n_sc: int, position_value: float, velocity_value: float) -> np.ndarray:
    """(6 n_sc, 6 n_sc) diagonal with the position value on position axes, velocity on velocity axes."""
    one = np.array([position_value] * 3 + [velocity_value] * 3)
    return np.diag(np.tile(one, n_sc))


@dataclass(frozen=True, eq=False)
class Problem:
    """Arrays of one scenario, all in LU / TU unless a name says otherwise.

    times_s (m,); truth (m, n) with n = 6 n_sc; measurements_true (m, L) noise-free (row 0 unused);
    link_receiver / link_transponder (L,); measurement channels (C): channel_link, channel_kind (see
    estimation.filter_loop), sigma_lu (C,) in LU, LU/TU or rad; bias_lu: constant range bias in the truth;
    bias_sigma_lu: sigma of the per-run random bias of each link; n_bias: bias states in the filter (0 or L),
    bias_mode: 0 ignore, 1 estimate, 2 consider (P0 / Q then have n_bias extra rows);
    P0, Q (n, n); initial_error_sigma (n,) for the 'fixed_sigma' draw.
    """

    scenario: Scenario
    spacecraft: tuple[str, ...]
    times_s: np.ndarray
    truth: np.ndarray
    measurements_true: np.ndarray
    link_receiver: np.ndarray
    link_transponder: np.ndarray
    channel_link: np.ndarray
    channel_kind: np.ndarray
    sigma_m: float
    sigma_lu: np.ndarray
    bias_lu: float
    P0: np.ndarray
    Q: np.ndarray
    initial_error_sigma: np.ndarray
    dt_tu: float
    substeps: int
    mu: float
    divergence_position_lu: float
    light_time_model: bool = False
    bias_sigma_lu: float = 0.0
    n_bias: int = 0
    bias_mode: int = 0

    @property
    def n_spacecraft(self) -> int:
        return len(self.spacecraft)

    @property
    def channel_scale_si(self) -> np.ndarray:
        """(C,) factors from filter units to m, m/s or rad."""
        return np.array([{KIND_RANGE: M_PER_LU, KIND_RANGE_RATE: M_S_PER_VU}.get(int(k), 1.0)
                         for k in self.channel_kind])

    @property
    def channel_labels(self) -> list[tuple[str, str, str]]:
        """(link label, observable, unit) per channel."""
        names = {KIND_RANGE: ("range", "m"), KIND_RANGE_RATE: ("range_rate", "m/s"),
                 KIND_AZIMUTH: ("azimuth", "rad"), KIND_ELEVATION: ("elevation", "rad")}
        out = []
        for link, kind in zip(self.channel_link, self.channel_kind):
            label = f"{self.spacecraft[self.link_receiver[link]]}->{self.spacecraft[self.link_transponder[link]]}"
            out.append((label, *names[int(kind)]))
        return out

    @property
    def n_steps(self) -> int:
        return self.times_s.shape[0]


def truth_key(scenario: Scenario) -> str:
    """The scenario fields that fix truth and noise-free measurements (not noise, filter or seed)."""
    fields = {
        "spacecraft": [{"orbit": sc.orbit, "elements": sc.elements and sc.elements.model_dump(),
                        "period_days": sc.period_days, "amplitude_km": sc.amplitude_km}
                       for sc in scenario.spacecraft],
        "links": [link.model_dump(mode="json") for link in scenario.links],
        "duration_days": scenario.duration_days,
        "interval_s": scenario.measurement.interval_s,
        "light_time": scenario.measurement.light_time,
    }
    return json.dumps(fields, sort_keys=True)


def measurement_times_s(scenario: Scenario) -> np.ndarray:
    """Epochs t0 = 0, interval, 2 interval, ... up to the scenario duration (m,)."""
    interval_s = scenario.measurement.interval_s
    n_intervals = int(np.floor(scenario.duration_days * SECONDS_PER_DAY / interval_s + 1e-9))
    return np.arange(n_intervals + 1) * interval_s


def _truth_and_measurements(scenario: Scenario):
    """times_s (m,), truth (m, n_sc, 6), noise-free measurements (m, L) with row 0 NaN, range models."""
    names = scenario.spacecraft_names()
    times_s = measurement_times_s(scenario)
    times_tu = times_s / TU_S
    truth_by_sc = np.stack(
        [propagate_states(initial_state_lu(sc), times_tu, MU) for sc in scenario.spacecraft], axis=1
    )
    index = {name: i for i, name in enumerate(names)}
    models = [TwoWayRange(index[link.receiver], index[link.transponder]) for link in scenario.links]
    columns = []
    for link_index, (link, model) in enumerate(zip(scenario.links, models)):
        for kind in channel_kinds(link.observables):
            columns.append(_simulate_channel(kind, model, truth_by_sc, scenario.measurement.light_time))
    measurements = np.stack(columns, axis=1)
    measurements[0, :] = np.nan  # the filter starts at t0 with no measurement
    return times_s, truth_by_sc, measurements, models


def channel_kinds(observables) -> list[int]:
    """Scalar measurement channels of one link, in a fixed order: range, range-rate, azimuth, elevation."""
    kinds = []
    if "range" in observables:
        kinds.append(KIND_RANGE)
    if "range_rate" in observables:
        kinds.append(KIND_RANGE_RATE)
    if "los" in observables:
        kinds += [KIND_AZIMUTH, KIND_ELEVATION]
    return kinds


def _simulate_channel(kind, model, truth_by_sc, light_time: bool) -> np.ndarray:
    """Noise-free truth of one channel. Range: two-way light time (Eq. 14-15) or geometric. Range-rate and
    LOS: instantaneous geometry at the reception time (their light-time terms are far below their noise)."""
    receiver, transponder = truth_by_sc[:, model.receiver], truth_by_sc[:, model.transponder]
    if kind == KIND_RANGE:
        return model.simulate(truth_by_sc, MU, light_time=light_time)
    if kind == KIND_RANGE_RATE:
        return np.array([range_rate(a, b) for a, b in zip(receiver, transponder)])
    angles = np.array([azimuth_elevation(a[:3], b[:3]) for a, b in zip(receiver, transponder)])
    return angles[:, 0] if kind == KIND_AZIMUTH else angles[:, 1]


def prepare_problem(scenario: Scenario, truth_cache: dict | None = None) -> Problem:
    """Build the arrays of a scenario. Pass the same `truth_cache` dict to a series of scenarios that
    differ only in noise / filter / seed (a sweep over sigma) and the truth is propagated once."""
    names = scenario.spacecraft_names()
    n_sc = len(names)
    interval_s = scenario.measurement.interval_s
    if truth_cache is None:
        times_s, truth_by_sc, measurements, models = _truth_and_measurements(scenario)
    else:
        key = truth_key(scenario)
        if key not in truth_cache:
            truth_cache[key] = _truth_and_measurements(scenario)
        times_s, truth_by_sc, measurements, models = truth_cache[key]

    sigma_m = scenario.noise.resolved_sigma_m()
    flt = scenario.filter
    dt_tu = interval_s / TU_S
    P0 = per_axis_block_diagonal(
        n_sc, (flt.initial_sigma_position_m / M_PER_LU) ** 2, (flt.initial_sigma_velocity_m_s / M_S_PER_VU) ** 2
    )
    # State-noise compensation, one 6x6 block per spacecraft: white acceleration sigma_a on each
    # velocity axis, q = (sigma_a dt)^2.
    q_diag = []
    for sc in scenario.spacecraft:
        sigma_a = flt.process_noise_accel_m_s2 if sc.process_noise_accel_m_s2 is None else sc.process_noise_accel_m_s2
        q_diag += [0.0] * 3 + [(sigma_a * interval_s / M_S_PER_VU) ** 2] * 3
    Q = np.diag(q_diag)
    ie = scenario.initial_error
    initial_error_sigma = np.diag(
        per_axis_block_diagonal(n_sc, ie.sigma_position_m / M_PER_LU, ie.sigma_velocity_m_s / M_S_PER_VU)
    ).copy()

    channel_link, channel_kind, channel_sigma = [], [], []
    by_name = {sc.name: sc for sc in scenario.spacecraft}
    for link_index, link in enumerate(scenario.links):
        for kind in channel_kinds(link.observables):
            channel_link.append(link_index)
            channel_kind.append(kind)
            if kind == KIND_RANGE:
                channel_sigma.append(sigma_m / M_PER_LU)
            elif kind == KIND_RANGE_RATE:
                channel_sigma.append(scenario.noise.resolved_range_rate_sigma_m_s() / M_S_PER_VU)
            else:
                channel_sigma.append(los_sigma_rad(scenario.noise.resolved_los_path_sigma_m(),
                                                   by_name[link.receiver].antenna_baseline_m))
    channel_link = np.array(channel_link, dtype=np.int64)
    channel_kind = np.array(channel_kind, dtype=np.int64)
    channel_sigma = np.array(channel_sigma)
    bias_mode = {"ignore": 0, "estimate": 1, "consider": 2}[flt.bias]
    n_bias = len(models) if bias_mode else 0
    if n_bias:
        apriori = (flt.bias_apriori_sigma_m / M_PER_LU) ** 2
        P0 = np.block([[P0, np.zeros((len(P0), n_bias))], [np.zeros((n_bias, len(P0))), apriori * np.eye(n_bias)]])
        Q = np.block([[Q, np.zeros((len(Q), n_bias))], [np.zeros((n_bias, len(Q))), np.zeros((n_bias, n_bias))]])
        initial_error_sigma = np.concatenate([initial_error_sigma, np.zeros(n_bias)])

    return Problem(
        scenario=scenario,
        spacecraft=tuple(names),
        times_s=times_s,
        truth=np.ascontiguousarray(truth_by_sc.reshape(len(times_s), 6 * n_sc)),
        measurements_true=np.ascontiguousarray(measurements),
        link_receiver=np.array([m.receiver for m in models], dtype=np.int64),
        link_transponder=np.array([m.transponder for m in models], dtype=np.int64),
        sigma_m=sigma_m,
        channel_link=channel_link,
        channel_kind=channel_kind,
        sigma_lu=channel_sigma,
        bias_lu=scenario.noise.bias_m / M_PER_LU,
        P0=P0,
        Q=Q,
        initial_error_sigma=initial_error_sigma,
        dt_tu=dt_tu,
        substeps=flt.rk4_substeps,
        mu=MU,
        divergence_position_lu=flt.divergence_position_km / LU_KM,
        light_time_model=flt.range_model == "light_time",
        bias_sigma_lu=scenario.noise.bias_sigma_m / M_PER_LU,
        n_bias=n_bias,
        bias_mode=bias_mode,
    )
