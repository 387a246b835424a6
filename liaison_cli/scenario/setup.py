"""Scenario -> arrays: the `Problem` a campaign runs, from the truth (scenario.truth: participants'
trajectories, visibility, noise-free measurements) and the estimator's arrays (scenario.filter_arrays:
layout, P0, Q, channel tables, what each run draws).

Everything here is computed once per scenario and shared (read-only) by every Monte Carlo run. What is
drawn per run (initial error, noise, biases, clock histories) is described here and drawn by the worker.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import M_PER_LU, SPEED_OF_LIGHT_M_S
from liaison_cli.dynamics.model import DynamicsModel
from liaison_cli.estimation.blocks import BLOCK_CONSTANT, ROLE_LINK_BIAS, owner_name
from liaison_cli.estimation.estimators import FilterArrays
from liaison_cli.scenario.links import link_label
from liaison_cli.scenario.filter_arrays import (
    Channel, ClockTruth, clock_truths, estimator_setup, initial_error_sigma, state_layout)
from liaison_cli.scenario.observed import observed_measurements
from liaison_cli.scenario.reference_states import initial_state_lu
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.scenario.truth import (
    GEOSTATIONARY_ALTITUDE_M, burn_step, dynamics_model, link_visibility, measurement_times_s,
    participant_trajectories, truth_and_measurements, unforced_participants)

# Names callers import from here (the worker, studies, reports).
__all__ = ["GEOSTATIONARY_ALTITUDE_M", "SPEED_OF_LIGHT_M_S", "Channel", "ClockTruth", "Problem", "burn_step",
           "dynamics_model", "initial_state_lu", "link_visibility", "measurement_times_s",
           "participant_trajectories", "prepare_problem", "state_layout"]


@dataclass(frozen=True, eq=False)
class Problem:
    """Arrays of one scenario, in LU / TU unless a name says otherwise.

    times_s (m,); truth (m, 6 n_sc) of the estimated spacecraft; measurements_true (m, C) noise-free (row 0
    unused, NaN where a channel sees nothing): both nominal, the shared truth of every run unless a random truth
    acceleration makes each run fly its own (campaign.engine.worker.run_truth); channels (C,) descriptions; filter: the estimator's arrays;
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
    # When each run flies its own truth (a random truth acceleration: scenario.truth.forced_truth_and_measurements),
    # the nominal trajectories of the participants it leaves alone (known spacecraft, ground stations), which
    # the workers receive with the problem; else None.
    unforced: dict | None = None
    # Each estimated spacecraft's integration step: {name: dynamics.step_choice.StepChoice}.
    step_choices: dict | None = None
    # The derived default process noise of the estimated spacecraft that name none: {name: DefaultNoise}.
    default_noises: dict | None = None

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


def prepare_problem(scenario: Scenario, truth_cache: dict | None = None) -> Problem:
    """Build the arrays of a scenario. Pass the same `truth_cache` dict to a series of scenarios that
    differ only in noise / filter / seed (a sweep over sigma) and the truth is propagated once."""
    model = dynamics_model(scenario)
    times_s, trajectories, measurements = truth_and_measurements(scenario, model, truth_cache)
    estimator = estimator_setup(scenario, model, times_s, trajectories)
    names = scenario.spacecraft_names()
    sc_index = {name: i for i, name in enumerate(names)}
    return Problem(
        scenario=scenario,
        spacecraft=tuple(names),
        link_labels=tuple(link_label(link) for link in scenario.links),
        link_ends=tuple((sc_index.get(link.receiver, -1), sc_index.get(link.transponder, -1))
                        for link in scenario.links),
        times_s=times_s,
        truth=np.ascontiguousarray(np.hstack([trajectories[name].states for name in names])),
        measurements_true=np.ascontiguousarray(measurements),
        channels=estimator.channels,
        filter=estimator.arrays,
        sigma_m=scenario.noise.resolved_sigma_m(),
        bias_lu=scenario.noise.resolved_bias_m() / M_PER_LU,
        bias_sigma_lu=scenario.noise.bias_sigma_m / M_PER_LU,
        bias_state_start=estimator.layout.start_of(BLOCK_CONSTANT, owner_name(ROLE_LINK_BIAS, 0)),
        clocks=clock_truths(scenario, estimator.channels, estimator.layout),
        initial_error_sigma=initial_error_sigma(scenario),
        dynamics=model,
        manoeuvres=estimator.manoeuvres,
        observed=observed_measurements(scenario, estimator.channels, times_s, model),
        unforced=(unforced_participants(scenario, trajectories)
                  if scenario.model_error.truth_acceleration_sigma_m_s2 > 0.0 else None),
        step_choices=estimator.step_choices,
        default_noises=estimator.default_noises,
    )
