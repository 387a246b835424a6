"""What the rest of liaison knows about an observable: a small description object per observable.

An observable (the word a scenario uses: `range`, `range_rate`, `los`, `pseudorange`) produces one or
more scalar channels (LOS: azimuth and elevation). For each channel the description gives its kind code
(dispatched by `measurements.registry.predict`), label, SI unit and the factor from filter units to SI.
It also says how the scenario's noise section sets each channel's sigma, how truth simulates the channel
from the two ends' trajectories, and which additive modifiers apply: a per-link range bias, the clocks
of the two ends. Nothing outside `measurements/` branches on an observable's kind.
"""

from dataclasses import dataclass
from typing import Callable

# Channel flag (bit 1; FLAG_LIGHT_TIME is bit 0, measurements.range): the ends' states are in the CRTBP
# frame, turning at 1 rad/TU about z, not an inertial one. Set on every channel of a CRTBP scenario; the
# light-time TDoA / FDoA turns its ends into the inertial frame of the epoch with it (measurements.tdoa).
FLAG_ROTATING_FRAME = 2


@dataclass(frozen=True)
class ChannelKind:
    code: int  # dispatch code of the compiled predict / partials
    label: str  # e.g. "range", "azimuth"
    unit: str  # SI unit of the channel: "m", "m/s", "rad"
    scale_si: float  # SI value of one filter unit (LU -> m, LU/TU -> m/s, rad -> rad)


@dataclass(frozen=True)
class Observable:
    """name: scenario word. channels: the scalar channels it yields, in order.

    sigma(noise, receiver) -> one 1-sigma per channel, in filter units; `noise` is the scenario's noise
    section and `receiver` the receiving participant's spec (duck-typed: no schema import here).
    simulate(code, receiver, transmitter, light_time) -> (m,) noise-free truth of one channel from the
    two ends' trajectories (objects with `.states` (m, 6) and `.inertial_position_before(dt_back_tu)`).
    takes_range_bias: a link's range bias adds to it (truth and, if modelled, filter).
    clock_coefficients: (receiver, transmitter) factors of the ends' clock phase (range units) in the
    value; (0, 0) for two-way observables, whose clock terms cancel. One pair for every channel, or a
    tuple of pairs, one per channel (dual one-way: the second pseudorange is timed by the other end).
    needs_receiver_clock / needs_both_clocks / needs_receiver_baseline: what the ends must carry;
    needs_second_receiver: the link names a second receiver (a third end) and simulate takes its trajectory.
    end_accelerations: the known participants' rows in the filter carry their accelerations after their
    states, (9,) instead of (6,) (dynamics.trajectory.states_with_accelerations).
    clock_offset_channel: index of the channel that measures the ends' clock offset (for synchronisation
    by a clock fit), or -1.
    """

    name: str
    channels: tuple[ChannelKind, ...]
    sigma: Callable
    simulate: Callable
    takes_range_bias: bool = False
    clock_coefficients: tuple = (0.0, 0.0)
    needs_receiver_clock: bool = False
    needs_both_clocks: bool = False
    clock_offset_channel: int = -1
    needs_receiver_baseline: bool = False
    needs_second_receiver: bool = False  # a three-end channel (TDoA / FDoA): simulate(..., second=trajectory)
    light_time_from_states: bool = False  # its light-time truth needs the ends' states and accelerations only
    end_accelerations: bool = False  # the filter's light-time model reads known ends' accelerations (below)
    filter_flags: Callable = lambda filter_spec: 0  # model options of the filter's prediction, as bit flags
    missing_noise: Callable = lambda noise: None  # what the noise section lacks for this observable, or None
    description: str = ""

    def channel_clock_coefficients(self, index: int) -> tuple[float, float]:
        """(receiver, transmitter) clock factors of channel `index`."""
        if isinstance(self.clock_coefficients[0], tuple):
            return self.clock_coefficients[index]
        return self.clock_coefficients
