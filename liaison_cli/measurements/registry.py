"""The observable registry and the compiled dispatch: the only code that branches on a channel's kind.

To add an observable: a new file in `measurements/` with its kind code, a compiled
`predict_<name>(x_receiver, x_transmitter, flags, g_receiver, g_transmitter) -> value` (three-end kinds
also take the second receiver) and an `OBSERVABLE` description; then one import and one branch in
`predict`, the single dispatch, which every estimator (EKF, initial batch, LinCov, batch) and `predict_along`
(the observability analysis) call. The kind is read at run time: a new kind is one more compiled function
behind a call, and no estimator is compiled again per kind set.
"""

import numpy as np
from numba import njit

from liaison_cli.measurements import dual_one_way, los, pseudorange, range as range_, range_rate, tdoa
from liaison_cli.measurements.dual_one_way import KIND_CLOCK_OFFSET, KIND_PSEUDORANGE_IJ, predict_dual_one_way
from liaison_cli.measurements.los import KIND_AZIMUTH, KIND_ELEVATION, predict_angle, wrap_angle
from liaison_cli.measurements.observable import ChannelKind, Observable
from liaison_cli.measurements.pseudorange import KIND_PSEUDORANGE, predict_pseudorange
from liaison_cli.measurements.range import KIND_RANGE, predict_range
from liaison_cli.measurements.range_rate import KIND_RANGE_RATE, predict_range_rate
from liaison_cli.measurements.tdoa import KIND_FDOA, KIND_TDOA, predict_difference

OBSERVABLES: dict[str, Observable] = {
    obs.name: obs for obs in (range_.OBSERVABLE, range_rate.OBSERVABLE, los.OBSERVABLE, pseudorange.OBSERVABLE,
                              dual_one_way.RAW, dual_one_way.DERIVED, tdoa.TDOA, tdoa.FDOA)
}
CHANNEL_KINDS: dict[int, ChannelKind] = {ch.code: ch for obs in OBSERVABLES.values() for ch in obs.channels}
assert len(CHANNEL_KINDS) == sum(len(obs.channels) for obs in OBSERVABLES.values()), "kind codes must be unique"
ALL_KINDS = sum(1 << code for code in CHANNEL_KINDS)


def observable_names() -> list[str]:
    return list(OBSERVABLES)


def get_observable(name: str) -> Observable:
    try:
        return OBSERVABLES[name]
    except KeyError:
        raise ValueError(f"unknown observable {name!r}; allowed: {', '.join(OBSERVABLES)}") from None


@njit(cache=True)  # a call, not inlined: compiled and cached once for every estimator (predict)
def _predict_angle(kind, x_receiver, x_transmitter, g_receiver, g_transmitter):
    return predict_angle(kind, x_receiver, x_transmitter, g_receiver, g_transmitter)


@njit(cache=True)  # a call, not inlined (see _predict_angle)
def _predict_pseudorange(x_receiver, x_transmitter, flags, g_receiver, g_transmitter):
    return predict_pseudorange(x_receiver, x_transmitter, flags, g_receiver, g_transmitter)


@njit(cache=True)  # a call, not inlined (see _predict_angle)
def _predict_dual_one_way(kind, x_receiver, x_transmitter, flags, g_receiver, g_transmitter):
    return predict_dual_one_way(kind, x_receiver, x_transmitter, flags, g_receiver, g_transmitter)


@njit(cache=True, inline="always")
def predict(kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter, g_second):
    """Predicted value of a channel of this kind (filter units) from its ends' states (6,) each; writes
    d(value)/d(end state) into g_receiver, g_transmitter, g_second (6,). x_second / g_second: the second
    receiver of a three-end channel (TDoA, FDoA); two-end kinds leave them alone. Clock and bias modifiers
    are added by the caller from the channel's modifier table (they are linear in their states).

    The kind is read at run time, so the EKF, the initial batch, LinCov and the batch are each compiled once
    for every kind set (docs/performance.md, "Compile once"); an unknown kind gives NaN, which the estimators
    stop on (never a silent wrong value). Range and range-rate, the crosslink observables of nearly every
    scenario, are written into the caller (a call per measurement would cost run time); every other kind is one
    compiled, cached function behind a call."""
    if kind == KIND_RANGE:
        return predict_range(x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
    if kind == KIND_RANGE_RATE:
        return predict_range_rate(x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
    if kind == KIND_AZIMUTH or kind == KIND_ELEVATION:
        return _predict_angle(kind, x_receiver, x_transmitter, g_receiver, g_transmitter)
    if kind == KIND_PSEUDORANGE:
        return _predict_pseudorange(x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
    if KIND_PSEUDORANGE_IJ <= kind <= KIND_CLOCK_OFFSET:
        return _predict_dual_one_way(kind, x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
    if kind == KIND_TDOA or kind == KIND_FDOA:
        return predict_difference(kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter,
                                  g_second)
    return np.nan


@njit(cache=True)
def predict_shared(kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter, g_second):
    """predict() behind one compiled, cached call, for every caller but the EKF's measurement row (the batch's
    row, LinCov's model on the truth, predict_along): there a call per measurement costs nothing measurable,
    and each inlined copy of predict (range, range-rate, TDoA and FDoA written in) was seconds of compiling."""
    return predict(kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter, g_second)


@njit(cache=True, inline="always")
def residual(kind, observed, predicted):
    """Observed minus predicted, angles wrapped into (-pi, pi]."""
    r = observed - predicted
    if kind == KIND_AZIMUTH:
        return wrap_angle(r)
    return r


@njit(cache=True)
def _predict_along(kind, receiver_states, transmitter_states, flags):
    m = receiver_states.shape[0]
    values = np.empty(m)
    g_receiver = np.empty((m, 6))
    g_transmitter = np.empty((m, 6))
    g_unused = np.empty(6)
    for k in range(m):
        values[k] = predict_shared(kind, receiver_states[k], transmitter_states[k], receiver_states[k], flags,
                            g_receiver[k], g_transmitter[k], g_unused)
    return values, g_receiver, g_transmitter


def predict_along(kind: int, receiver_states, transmitter_states, flags: int):
    """predict() of a two-end kind at every epoch: (m, 6), (m, 6) -> values (m,), d/d(receiver) (m, 6),
    d/d(transmitter) (m, 6)."""
    return _predict_along(int(kind), np.ascontiguousarray(receiver_states, dtype=float),
                          np.ascontiguousarray(transmitter_states, dtype=float), int(flags))
