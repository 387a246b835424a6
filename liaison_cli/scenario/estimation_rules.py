"""The rules between sections that the estimator's choice owns: its own settings section, the states it carries
(clock-timed observables need clock states or clock synchronisation), considered biases, the residual gate,
the batch and the initial batch against the measurement epochs, the smoother, clock synchronisation.
Scenario._consistent calls them in order; each raises ValueError with a one-line message, asking the
estimator's descriptor (estimation.estimators) rather than comparing names."""

from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.estimation.estimator import Estimator
from liaison_cli.estimation.estimators import ESTIMATORS, estimators_that
from liaison_cli.measurements.registry import OBSERVABLES

# Each estimator's own settings section (the JSON Schema's view of the descriptors too).
OWN_SECTIONS = [(e.name, e.settings_section) for e in ESTIMATORS.values() if e.settings_section is not None]


def check_estimator(scenario):
    """What the chosen estimator carries and supports, asked of its descriptor: its own settings section
    (given exactly when it is chosen), clock-timed observables, considered biases, the residual gate."""
    for name, section in OWN_SECTIONS:
        given_section = getattr(scenario, section) is not None
        if (scenario.estimator == name) != given_section:
            raise ValueError(f"key 'estimator' = {scenario.estimator!r} "
                             f"{'with' if given_section else 'without'} a '{section}' section: estimator: {name} "
                             f"and a '{section}' section go together (give both or neither)")
    estimator = scenario.estimator_descriptor()
    if not estimator.carries_clocks:
        check_no_clock_states(scenario, estimator)
    if scenario.filter.bias == "estimate" and not estimator.carries_biases:
        raise ValueError(f"filter.bias = 'estimate' with estimator: {scenario.estimator}, which carries no bias "
                         f"states; allowed with estimator: {' / '.join(estimators_that('carries_biases'))}")
    if scenario.filter.bias == "consider" and not estimator.consider:
        raise ValueError(f"filter.bias = 'consider' with estimator: {scenario.estimator}, which has no consider "
                         f"treatment (it would estimate the bias); allowed: bias estimate or ignore, or estimator: "
                         f"{' / '.join(estimators_that('consider'))}")
    if scenario.filter.residual_gate_sigma is not None and not estimator.residual_gate:
        raise ValueError(f"filter.residual_gate_sigma = {scenario.filter.residual_gate_sigma:g} gates the EKF's "
                         f"pre-fit innovations; the {scenario.estimator} estimator (estimator: {scenario.estimator}) has "
                         "no residual gate: remove the key or use estimator: "
                         f"{' / '.join(estimators_that('residual_gate'))}")


def check_no_clock_states(scenario, estimator: Estimator):
    for i, link in enumerate(scenario.links):
        for observable in link.observables:
            spec = OBSERVABLES[observable]
            if spec.needs_receiver_clock or any(
                    spec.channel_clock_coefficients(c) != (0.0, 0.0) and c != spec.clock_offset_channel
                    for c in range(len(spec.channels))):
                raise ValueError(f"links[{i}] measures {observable!r}, whose value carries clock states: the "
                                 f"{estimator.name} estimator solves for orbits only; use dual_one_way_derived "
                                 "(range + clock offset, synchronised by clock_sync) or the "
                                 f"{' / '.join(estimators_that('carries_clocks'))}")


def check_initial_batch(scenario):
    """The initial batch window: at least two measurement intervals, inside the scenario, before any
    manoeuvre (the window's solve has no burn), and only in front of an EKF without a smoother or consider
    parameters (the smoother would smooth only the EKF's part; consider blocks would be solved for)."""
    flt = scenario.filter
    if flt.initial_batch_hours is None:
        return
    longest_h = flt.initial_batch_max_hours or flt.initial_batch_hours
    shortest_h = 2.0 * scenario.measurement.interval_s / 3600.0
    if flt.initial_batch_hours < shortest_h - 1e-9:
        raise ValueError(f"filter.initial_batch_hours = {flt.initial_batch_hours:g} is shorter than two "
                         f"measurement intervals; allowed: at least {shortest_h:g} h")
    scenario_h = scenario.epochs_end_days() * 24.0
    if longest_h >= scenario_h - scenario.measurement.interval_s / 3600.0 + 1e-9:
        key = "initial_batch_max_hours" if flt.initial_batch_max_hours else "initial_batch_hours"
        raise ValueError(f"filter.{key} = {longest_h:g} leaves the EKF no data: allowed: shorter than the "
                         f"scenario's {scenario_h:g} h less one measurement interval")
    if not scenario.estimator_descriptor().initial_batch:
        raise ValueError(f"filter.initial_batch_hours with estimator: {scenario.estimator}: not supported (allowed "
                         f"with estimator: {' / '.join(estimators_that('initial_batch'))})")
    if flt.smoother != "none":
        raise ValueError("filter.initial_batch_hours with filter.smoother = 'rts': not supported (the smoother "
                         "would cover only the EKF's part of the arc)")
    if flt.bias == "consider":
        raise ValueError("filter.initial_batch_hours with filter.bias = 'consider': not supported (the batch "
                         "would solve for the considered bias)")
    for i, sc in enumerate(scenario.spacecraft):
        if sc.manoeuvre is not None and sc.manoeuvre.epoch_days * 24.0 < longest_h + 1e-9:
            raise ValueError(f"spacecraft[{i}].manoeuvre.epoch_days = {sc.manoeuvre.epoch_days:g} falls inside "
                             f"the initial batch window ({longest_h:g} h); allowed: after it")


def check_batch_section(scenario):
    """The batch section's spans against the scenario's epochs."""
    if scenario.batch is None:
        return
    end_days = scenario.batch.end_days()
    if end_days > scenario.duration_days + 1e-9:
        windows = f" over {scenario.batch.windows} windows" if scenario.batch.windows > 1 else ""
        raise ValueError(f"batch.span_days = {scenario.batch.span_days:g} plus prediction_hours = "
                         f"{scenario.batch.prediction_hours:g}{windows} is {end_days:g} d, longer than the "
                         f"scenario's duration_days = {scenario.duration_days:g}")
    if scenario.batch.renewal_hours is not None and (
            abs(scenario.batch.renewal_hours * 3600.0 / scenario.measurement.interval_s
                - round(scenario.batch.renewal_hours * 3600.0 / scenario.measurement.interval_s)) > 1e-9):
        raise ValueError(f"batch.renewal_hours = {scenario.batch.renewal_hours:g} is not a whole number of "
                         f"measurement intervals ({scenario.measurement.interval_s:g} s)")
    if scenario.batch.span_days * SECONDS_PER_DAY < 2.0 * scenario.measurement.interval_s:
        raise ValueError(f"batch.span_days = {scenario.batch.span_days:g} is shorter than two measurement "
                         f"intervals ({scenario.measurement.interval_s:g} s)")


def check_smoother(scenario):
    """The RTS pass smooths the EKF's own forward record: no batch, no consider parameters (their zero-gain
    covariance is not the record of an optimal filter) and no manoeuvre (its jump is not in the stored
    transitions)."""
    if scenario.filter.smoother == "none":
        return
    if not scenario.estimator_descriptor().smoother:
        raise ValueError(f"filter.smoother = 'rts' smooths a filter's pass; estimator: {scenario.estimator} takes no "
                         f"smoother (allowed with estimator: {' / '.join(estimators_that('smoother'))})")
    if scenario.filter.bias == "consider":
        raise ValueError("filter.smoother = 'rts' with filter.bias = 'consider': not supported (estimate or "
                         "ignore the bias)")
    if scenario.filter.underweighting > 0:
        raise ValueError(f"filter.smoother = 'rts' with filter.underweighting = {scenario.filter.underweighting:g}: "
                         "the RTS recursion assumes the optimal gain; allowed: underweighting 0 with the smoother")
    moving = [sc.name for sc in scenario.spacecraft if sc.manoeuvre is not None]
    if moving:
        raise ValueError(f"filter.smoother = 'rts' with a manoeuvre ({moving[0]!r}): not supported")


def check_clock_sync(scenario):
    if scenario.clock_sync is None:
        return
    window_s = scenario.clock_sync.window_hours * 3600.0
    if window_s < 2.0 * scenario.measurement.interval_s:
        raise ValueError(f"clock_sync.window_hours = {scenario.clock_sync.window_hours:g} is shorter than two "
                         f"measurement intervals ({scenario.measurement.interval_s:g} s)")
    if not any(OBSERVABLES[o].clock_offset_channel >= 0 for link in scenario.links for o in link.observables):
        raise ValueError("clock_sync needs a link that measures clock offsets (observable dual_one_way_derived)")
