"""The observable registry and the compiled dispatch: the only code that branches on a channel's kind.

To add an observable: a new file in `measurements/` with its kind code, a compiled
`predict_<name>(x_receiver, x_transmitter, flags, g_receiver, g_transmitter) -> value` (three-end kinds
also take the second receiver) and an `OBSERVABLE` description; then one import and one branch in
`predict_for`, the single dispatch: the EKF, the initial batch and LinCov compile it for their scenario's
kinds, as does `predict_along` (the observability analysis) for its one; `predict` (the batch, tests) for all.
"""

import numba
import numpy as np
from numba import njit, types
from numba.core.errors import TypingError
from numba.extending import overload

from liaison_cli.dynamics.model import literal_entry
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


# Kinds compiled into every kind set: range and range-rate, the crosslink observables of nearly every scenario.
# Measured on eml2_lunar (range only), one process, empty cache: its first run took 11.2 s of CPU compiling
# range alone, 11.8 s with range-rate in (with the angles too, 12.9 s), and a run the same time; the test suite's
# filter specialisations go from eight (range; range-rate; both; ...) to six.
ALWAYS_COMPILED_KINDS = (1 << KIND_RANGE) | (1 << KIND_RANGE_RATE)


def kinds_mask(channel_kinds) -> int:
    """The bit set of the kind codes a scenario's channels use, plus ALWAYS_COMPILED_KINDS (predict_for's
    compile-time constant)."""
    mask = ALWAYS_COMPILED_KINDS
    for kind in channel_kinds:
        mask |= 1 << int(kind)
    return mask


def predict_for(kinds, kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter, g_second):
    """predict() compiled for the kinds in the bit set `kinds` only (a compile-time constant: the caller
    says numba.literally(kinds)). A scenario's filter loop then carries the code of its own observables and
    not the others' (light-time TDoA paths, dual one-way, angles): less to compile on a first run."""
    raise NotImplementedError("predict_for is compiled code; call it from a numba function")


@overload(predict_for, inline="always")
def _predict_for(kinds, kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter, g_second):
    if not isinstance(kinds, types.IntegerLiteral):
        raise TypingError("predict_for: the kind set must be a compile-time constant (numba.literally)")
    mask = kinds.literal_value
    has = [bool(mask >> code & 1) for code in range(max(CHANNEL_KINDS) + 1)]
    use_range, use_rate = has[KIND_RANGE], has[KIND_RANGE_RATE]
    use_angle = has[KIND_AZIMUTH] or has[KIND_ELEVATION]
    use_pseudorange = has[KIND_PSEUDORANGE]
    use_dual = any(has[KIND_PSEUDORANGE_IJ : KIND_CLOCK_OFFSET + 1])
    use_difference = has[KIND_TDOA] or has[KIND_FDOA]

    def impl(kinds, kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter, g_second):
        if use_range and kind == KIND_RANGE:
            return predict_range(x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
        if use_rate and kind == KIND_RANGE_RATE:
            return predict_range_rate(x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
        if use_angle and (kind == KIND_AZIMUTH or kind == KIND_ELEVATION):
            return predict_angle(kind, x_receiver, x_transmitter, g_receiver, g_transmitter)
        if use_pseudorange and kind == KIND_PSEUDORANGE:
            return predict_pseudorange(x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
        if use_dual and KIND_PSEUDORANGE_IJ <= kind <= KIND_CLOCK_OFFSET:
            return predict_dual_one_way(kind, x_receiver, x_transmitter, flags, g_receiver, g_transmitter)
        if use_difference and (kind == KIND_TDOA or kind == KIND_FDOA):
            return predict_difference(kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter,
                                      g_second)
        return np.nan

    return impl


@njit(cache=True, inline="always")
def predict(kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter, g_second):
    """Predicted value of a channel of this kind (filter units) from its ends' states (6,) each; writes
    d(value)/d(end state) into g_receiver, g_transmitter, g_second (6,). x_second / g_second: the second
    receiver of a three-end channel (TDoA, FDoA); two-end kinds leave them alone. Clock and bias modifiers
    are added by the caller from the channel's modifier table (they are linear in their states).
    Every kind is compiled in; a filter loop uses predict_for with its scenario's kinds only."""
    return predict_for(ALL_KINDS, kind, x_receiver, x_transmitter, x_second, flags, g_receiver, g_transmitter,
                       g_second)


@njit(cache=True, inline="always")
def residual(kind, observed, predicted):
    """Observed minus predicted, angles wrapped into (-pi, pi]."""
    r = observed - predicted
    if kind == KIND_AZIMUTH:
        return wrap_angle(r)
    return r


@njit(cache=True)
def _predict_along(kinds, kind, receiver_states, transmitter_states, flags):
    numba.literally(kinds)
    m = receiver_states.shape[0]
    values = np.empty(m)
    g_receiver = np.empty((m, 6))
    g_transmitter = np.empty((m, 6))
    g_unused = np.empty(6)
    for k in range(m):
        values[k] = predict_for(kinds, kind, receiver_states[k], transmitter_states[k], receiver_states[k], flags,
                                g_receiver[k], g_transmitter[k], g_unused)
    return values, g_receiver, g_transmitter


def predict_along(kind: int, receiver_states, transmitter_states, flags: int):
    """predict() of a two-end kind at every epoch: (m, 6), (m, 6) -> values (m,), d/d(receiver) (m, 6),
    d/d(transmitter) (m, 6). Compiled for that kind (with ALWAYS_COMPILED_KINDS), not for every kind."""
    args = (kinds_mask([kind]), int(kind), receiver_states, transmitter_states, int(flags))
    return literal_entry(_predict_along, args, 0)(*args)
