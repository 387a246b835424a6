"""A scenario's measurements from a TDM (measurements: {tdm: FILE}), and the TDM form of each channel.

Each channel with a TDM keyword is one track: its participants (the link's receiver, transponder and, for a
difference, second receiver) and its signal path(s):

- range: RANGE (km), two-way path receiver, transponder, receiver;
- range-rate: DOPPLER_INSTANTANEOUS (km/s), the same path;
- pseudorange and dual one-way pseudoranges: RANGE (km) on the one-way path (transponder to receiver; the
  dual one-way's j->i leg the other way), the clocks' offset included as measured;
- dual one-way clock offset: CLOCK_BIAS (s), one-way path transponder to receiver;
- TDoA: DOR (s), SINGLE_DIFF with PATH_1 transponder to receiver and PATH_2 transponder to second receiver.

FDoA and the LOS angles have no TDM keyword here (FDoA is a difference of Doppler, for which TDM has none; the
LOS angles are inter-satellite angles in a local frame TDM's ANGLE_TYPE values do not name): they are not
written to a TDM, and a scenario read from a TDM gets no measurement on them. Values are as observed (noise,
biases and clock offsets in them), time-tagged at reception.
"""

import logging
from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import SPEED_OF_LIGHT_KM_S
from liaison_cli.errors import ExchangeFileError

TWO_WAY, ONE_WAY, ONE_WAY_BACK, DIFFERENCE = "two-way", "one-way", "one-way back", "difference"
# channel label -> (TDM keyword, factor from the channel's SI unit to the keyword's unit, path form)
CHANNEL_TRACKS = {
    "range": ("RANGE", 1e-3, TWO_WAY),
    "range_rate": ("DOPPLER_INSTANTANEOUS", 1e-3, TWO_WAY),
    "pseudorange": ("RANGE", 1e-3, ONE_WAY),
    "pseudorange_ij": ("RANGE", 1e-3, ONE_WAY),
    "pseudorange_ji": ("RANGE", 1e-3, ONE_WAY_BACK),
    "clock_offset": ("CLOCK_BIAS", 1e-3 / SPEED_OF_LIGHT_KM_S, ONE_WAY),
    "tdoa": ("DOR", 1.0, DIFFERENCE),
}
GRID_TOLERANCE_S = 1e-3  # a TDM epoch this close to a measurement epoch is that epoch (tags print microseconds)


@dataclass(frozen=True, eq=False)
class ObservedMeasurements:
    """values (m, C) in filter units, NaN where the file has nothing; run: whose draws the filter takes."""

    path: str
    values: np.ndarray
    run: int


def channel_track(scenario, channel):
    """(keyword, SI -> TDM factor, participants, paths) of a channel, or None when it has no TDM keyword."""
    form = CHANNEL_TRACKS.get(channel.label)
    if form is None:
        return None
    keyword, factor, path_form = form
    link = scenario.links[channel.link]
    receiver, transponder, second = link.receiver, link.transponder, link.second_receiver
    participants = (receiver, transponder) + ((second,) if second is not None else ())
    paths = {TWO_WAY: ((receiver, transponder, receiver),), ONE_WAY: ((transponder, receiver),),
             ONE_WAY_BACK: ((receiver, transponder),),
             DIFFERENCE: ((transponder, receiver), (transponder, second))}[path_form]
    return keyword, factor, participants, paths


def _grid_index(path, track, times_s, epoch_s: float) -> np.ndarray:
    offsets = track.seconds - epoch_s
    index = np.rint(np.interp(offsets, times_s, np.arange(len(times_s)))).astype(int)
    off_grid = np.abs(times_s[index] - offsets) > GRID_TOLERANCE_S
    outside = (offsets < times_s[0] - GRID_TOLERANCE_S) | (offsets > times_s[-1] + GRID_TOLERANCE_S)
    if outside.any() or off_grid.any():
        bad = int(np.argmax(outside | off_grid))
        why = "outside the scenario's span" if outside[bad] else "not a measurement epoch (t0 + k interval_s)"
        raise ExchangeFileError(f"{path}: {track.keyword} epoch {track.tags[bad]} ({track.time_system}): {why}")
    return index


def observed_measurements(scenario, channels, times_s, model) -> ObservedMeasurements | None:
    """The scenario's TDM on its channels (None without measurements: {tdm})."""
    spec = scenario.measurements
    if spec is None:
        return None
    from liaison_cli.exchange.tdm import read_tdm

    path = spec.tdm
    dated = scenario.dynamics_descriptor().dated
    epoch_s = model.epoch_tdb_s if dated else 0.0
    names = set(scenario.participant_names())
    signatures = {}
    for c, channel in enumerate(channels):
        form = channel_track(scenario, channel)
        if form is not None:
            signatures[(form[0], form[3])] = (c, form[1] * channel.scale_si)
    values = np.full((len(times_s), len(channels)), np.nan)
    for track in read_tdm(path):
        stranger = [p for p in track.participants if p not in names]
        if stranger:
            raise ExchangeFileError(f"{path}: participant {stranger[0]!r} is not in the scenario; its participants: "
                                    f"{', '.join(sorted(names))}")
        if (track.time_system == "MET") == dated:
            allowed = "TDB, TT, UTC" if dated else "MET (elapsed from t0)"
            raise ExchangeFileError(f"{path}: TIME_SYSTEM = {track.time_system}: not supported for a "
                                    f"{scenario.dynamics} scenario; allowed: {allowed}")
        key = (track.keyword, track.paths)
        if key not in signatures:
            route = " / ".join(",".join(p) for p in track.paths)
            raise ExchangeFileError(f"{path}: {track.keyword} on path {route}: no such channel in the scenario's links")
        column, to_tdm = signatures[key]
        values[_grid_index(path, track, times_s, epoch_s), column] = track.values / to_tdm
    values[0] = np.nan  # the filter starts at t0 with no measurement
    for c, channel in enumerate(channels):
        if np.isnan(values[:, c]).all():
            logging.getLogger("liaison").warning("%s: no measurement of %s on %s in %s", scenario.name, channel.label,
                                                 channel.link_label, path)
    return ObservedMeasurements(path, values, spec.run)
