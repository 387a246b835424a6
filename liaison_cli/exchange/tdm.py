"""TDM (CCSDS 503.0-B-2, version 2.0) <-> arrays: one track per segment (its participants, its signal path(s),
one data keyword), through ccsds-ndm. Which liaison channel a track carries is decided by the caller
(scenario.observed on reading, campaign.exchange.export on writing)."""

from dataclasses import dataclass

import numpy as np

from liaison_cli.errors import ExchangeFileError
from liaison_cli.exchange import library
from liaison_cli.exchange.oem import ORIGINATOR
from liaison_cli.exchange.timetags import READABLE_TIME_SYSTEMS, tags_to_seconds

# The data keywords liaison writes and reads, with their TDM units.
KEYWORD_UNITS = {"RANGE": "km", "DOPPLER_INSTANTANEOUS": "km/s", "DOR": "s", "CLOCK_BIAS": "s"}
MAX_PARTICIPANTS = 5
# What a RANGE value means, said in the segment's COMMENT lines: TDM leaves a range in km open to a one-way or a
# round-trip distance, and liaison's two-way range is the one-way equivalent (issue 35).
RANGE_TWO_WAY_COMMENT = ("RANGE convention: the one-way equivalent of the two-way measurement, half the round-trip "
                         "light path along PATH (km); the round trip is twice it")
RANGE_ONE_WAY_COMMENT = ("RANGE convention: a one-way pseudorange along PATH (km): the light path plus the clocks' "
                         "offset, as measured")


# A DOPPLER_INSTANTANEOUS value is a range rate in km/s (TDM 2.0); its sign and leg count are said as for RANGE.
DOPPLER_TWO_WAY_COMMENT = ("DOPPLER_INSTANTANEOUS convention: the range rate along PATH at the tag (km/s), positive "
                           "when the range grows (receding), the one-way equivalent of the two-way measurement: half "
                           "the round trip's rate; the Doppler shift of the round trip is -2 f / c times it")
DOPPLER_ONE_WAY_COMMENT = ("DOPPLER_INSTANTANEOUS convention: the one-way range rate along PATH at the tag (km/s), "
                           "positive when the range grows (receding); the one-way Doppler shift is -f / c times it")


def data_convention(keyword: str, paths: tuple) -> tuple:
    """The COMMENT lines that state what a track's values mean: a RANGE's or a DOPPLER_INSTANTANEOUS's legs, sign
    and units (none for another keyword, whose meaning TDM fixes)."""
    round_trip = any(len(path) > 2 and path[0] == path[-1] for path in paths)
    if keyword == "RANGE":
        return (RANGE_TWO_WAY_COMMENT if round_trip else RANGE_ONE_WAY_COMMENT,)
    if keyword == "DOPPLER_INSTANTANEOUS":
        return (DOPPLER_TWO_WAY_COMMENT if round_trip else DOPPLER_ONE_WAY_COMMENT,)
    return ()


@dataclass(frozen=True, eq=False)
class Track:
    """participants: names (PARTICIPANT_1 ..); paths: one path (SEQUENTIAL) or two (SINGLE_DIFF), each a tuple of
    participant names in signal order; keyword: a KEYWORD_UNITS key; tags / seconds / values (k,), values in the
    keyword's unit."""

    participants: tuple
    paths: tuple
    keyword: str
    time_system: str
    tags: list
    seconds: np.ndarray
    values: np.ndarray
    comments: tuple = ()


def _path_text(track: Track, path) -> str:
    return ",".join(str(track.participants.index(name) + 1) for name in path)


def tdm_message(tracks: list[Track], creation_date: str, comments=()):
    """The ccsds-ndm Tdm of the tracks, one segment each."""
    _, master = library.models()
    from ccsds_ndm.models.ndmxml4 import ndmxml_4_0_0_tdm_2_0 as tdm

    segments = []
    for track in tracks:
        names = {f"participant_{i + 1}": name for i, name in enumerate(track.participants)}
        if len(track.paths) == 1:
            paths = {"mode": tdm.ModeType.SEQUENTIAL, "path": _path_text(track, track.paths[0])}
        else:
            paths = {"mode": tdm.ModeType.SINGLE_DIFF, "path_1": _path_text(track, track.paths[0]),
                     "path_2": _path_text(track, track.paths[1])}
        extra = {"range_units": tdm.RangeUnitsType.KM} if track.keyword == "RANGE" else {}
        metadata = tdm.TdmMetadata(comment=list(track.comments), time_system=track.time_system,
                                   start_time=track.tags[0], stop_time=track.tags[-1],
                                   timetag_ref=tdm.TimetagRefType.RECEIVE, **names, **paths, **extra)
        key = track.keyword.lower()
        observations = [tdm.TrackingDataObservationType(epoch=tag, **{key: float(value)})
                        for tag, value in zip(track.tags, track.values)]
        segments.append(tdm.TdmSegment(metadata=metadata, data=tdm.TdmData(observation=observations)))
    header = tdm.TdmHeader(creation_date=creation_date, originator=ORIGINATOR, comment=list(comments))
    return master.Tdm(header=header, body=tdm.TdmBody(segment=segments))


def _enum_text(value) -> str | None:
    return None if value is None else str(getattr(value, "value", value)).upper()


def _paths(path, meta) -> tuple:
    participants = [getattr(meta, f"participant_{i}") for i in range(1, MAX_PARTICIPANTS + 1)]
    texts = [meta.path] if meta.path else [p for p in (meta.path_1, meta.path_2) if p]
    if not texts:
        raise ExchangeFileError(f"{path}: a segment has no PATH (or PATH_1 / PATH_2)")
    out = []
    for text in texts:
        try:
            indices = [int(i) for i in str(text).split(",")]
        except ValueError:
            raise ExchangeFileError(f"{path}: PATH = {text!r}: not comma-separated participant numbers") from None
        if any(not 1 <= i <= MAX_PARTICIPANTS or participants[i - 1] is None for i in indices):
            raise ExchangeFileError(f"{path}: PATH = {text!r} names a participant the segment does not give")
        out.append(tuple(participants[i - 1] for i in indices))
    return tuple(p for p in participants if p is not None), tuple(out)


def _segment_tracks(path, segment) -> list[Track]:
    meta = segment.metadata
    if meta.time_system not in READABLE_TIME_SYSTEMS:
        raise ExchangeFileError(f"{path}: TIME_SYSTEM = {meta.time_system}: not supported; allowed: "
                                f"{', '.join(READABLE_TIME_SYSTEMS)}")
    units = _enum_text(meta.range_units)
    timetag_ref = _enum_text(getattr(meta, "timetag_ref", None))
    if timetag_ref not in (None, "RECEIVE"):  # read as receive time, it would shift every epoch silently
        raise ExchangeFileError(f"{path}: TIMETAG_REF = {timetag_ref}: not read; allowed: RECEIVE (liaison's "
                                "measurements are tagged at reception)")
    participants, paths = _paths(path, meta)
    by_keyword: dict[str, list] = {}
    for observation in segment.data.observation:
        given = [k for k, v in vars(observation).items() if k != "epoch" and v is not None]
        for key in given:
            keyword = key.upper()
            if keyword not in KEYWORD_UNITS:
                raise ExchangeFileError(f"{path}: data keyword {keyword} is not read by liaison; allowed: "
                                        f"{', '.join(KEYWORD_UNITS)}")
            if keyword == "RANGE" and units not in (None, "KM"):
                raise ExchangeFileError(f"{path}: RANGE_UNITS = {units}: only km is read")
            value = float(getattr(observation, key))
            if not np.isfinite(value):  # as the OEM reader: a non-finite value is refused, not dropped
                raise ExchangeFileError(f"{path}: {keyword} = {value} at {observation.epoch}: not a finite "
                                        "number; allowed: finite values (leave a missing one out of the file)")
            by_keyword.setdefault(keyword, []).append((observation.epoch, value))
    tracks = []
    for keyword, rows in by_keyword.items():
        tags = [tag for tag, _ in rows]
        try:
            seconds = tags_to_seconds(tags, meta.time_system)
        except ValueError as exc:
            raise ExchangeFileError(f"{path}: {exc}") from None
        tracks.append(Track(participants, paths, keyword, meta.time_system, tags, seconds,
                            np.array([v for _, v in rows]), tuple(meta.comment)))
    return tracks


def read_tdm(path) -> list[Track]:
    """Every track of a TDM file: one per segment and data keyword."""
    message = library.read_message(path, "TDM")
    if not message.body.segment or not any(seg.data.observation for seg in message.body.segment):
        raise ExchangeFileError(f"{path}: malformed CCSDS message (no segment with data: META_START ... META_STOP, "
                                "DATA_START ... DATA_STOP)")
    return [track for segment in message.body.segment for track in _segment_tracks(path, segment)]
