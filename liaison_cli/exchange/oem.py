"""OEM (CCSDS 502.0-B-3, version 3.0) <-> arrays: one object's states (km, km/s) at tagged epochs, and optionally
its 6x6 covariances (km**2, km**2/s, km**2/s**2), through ccsds-ndm."""

from dataclasses import dataclass, field

import numpy as np

from liaison_cli.errors import ExchangeFileError
from liaison_cli.exchange import library
from liaison_cli.exchange.timetags import READABLE_TIME_SYSTEMS, tags_to_seconds

ORIGINATOR = "LIAISON"
COVARIANCE_KEYS = ("cx_x", "cy_x", "cy_y", "cz_x", "cz_y", "cz_z", "cx_dot_x", "cx_dot_y", "cx_dot_z", "cx_dot_x_dot",
                   "cy_dot_x", "cy_dot_y", "cy_dot_z", "cy_dot_x_dot", "cy_dot_y_dot", "cz_dot_x", "cz_dot_y",
                   "cz_dot_z", "cz_dot_x_dot", "cz_dot_y_dot", "cz_dot_z_dot")
LOWER_TRIANGLE = [(i, j) for i in range(6) for j in range(i + 1)]  # the order of COVARIANCE_KEYS


@dataclass(frozen=True, eq=False)
class Ephemeris:
    """One object's states: tags (m,) as written, seconds (m,) from them (TDB s past J2000, or MET s), states_km
    (m, 6); covariances: {line index: (6, 6)}."""

    object_name: str
    object_id: str
    centre: str
    frame: str
    time_system: str
    tags: list
    seconds: np.ndarray
    states_km: np.ndarray
    interpolation: str = "LAGRANGE"
    degree: int = 7
    covariances: dict = field(default_factory=dict)
    comments: tuple = ()


def _covariance_entry(common, key: str, value: float):
    kind = ("PositionVelocityCovarianceType" if "_dot_" in key and not key.endswith("_dot") else
            "VelocityCovarianceType" if key.startswith("c") and key.count("_dot") == 2 else "PositionCovarianceType")
    return getattr(common, kind)(value=float(value))


def oem_message(ephemeris: Ephemeris, creation_date: str):
    """The ccsds-ndm Oem of one object (one segment)."""
    common, master = library.models()
    from ccsds_ndm.models.ndmxml4 import ndmxml_4_0_0_oem_3_0 as oem

    vectors = [common.StateVectorAccType(
        epoch=tag, x=common.PositionTypeUo(value=float(s[0])), y=common.PositionTypeUo(value=float(s[1])),
        z=common.PositionTypeUo(value=float(s[2])), x_dot=common.VelocityTypeUo(value=float(s[3])),
        y_dot=common.VelocityTypeUo(value=float(s[4])), z_dot=common.VelocityTypeUo(value=float(s[5])))
        for tag, s in zip(ephemeris.tags, ephemeris.states_km)]
    matrices = []
    for index, matrix in sorted(ephemeris.covariances.items()):
        entries = {key: _covariance_entry(common, key, matrix[i, j]) for key, (i, j) in zip(COVARIANCE_KEYS,
                                                                                          LOWER_TRIANGLE)}
        matrices.append(common.OemCovarianceMatrixType(epoch=ephemeris.tags[index], cov_ref_frame=ephemeris.frame,
                                                       **entries))
    metadata = oem.OemMetadata(
        object_name=ephemeris.object_name, object_id=ephemeris.object_id, center_name=ephemeris.centre,
        ref_frame=ephemeris.frame, time_system=ephemeris.time_system, start_time=ephemeris.tags[0],
        stop_time=ephemeris.tags[-1], interpolation=ephemeris.interpolation,
        interpolation_degree=ephemeris.degree, comment=list(ephemeris.comments))
    data = oem.OemData(state_vector=vectors, covariance_matrix=matrices)
    return master.Oem(header=common.OdmHeader(creation_date=creation_date, originator=ORIGINATOR),
                      body=oem.OemBody(segment=[oem.OemSegment(metadata=metadata, data=data)]))


def _value(quantity) -> float:
    return float(quantity.value if hasattr(quantity, "value") else quantity)


def _segment_arrays(path, segment):
    meta = segment.metadata
    vectors = segment.data.state_vector
    if not vectors:
        raise ExchangeFileError(f"{path}: segment of {meta.object_name!r} has no state lines")
    if meta.time_system not in READABLE_TIME_SYSTEMS:
        raise ExchangeFileError(f"{path}: TIME_SYSTEM = {meta.time_system}: not supported; allowed: "
                                f"{', '.join(READABLE_TIME_SYSTEMS)}")
    tags = [v.epoch for v in vectors]
    try:
        seconds = tags_to_seconds(tags, meta.time_system)
    except ValueError as exc:
        raise ExchangeFileError(f"{path}: {exc}") from None
    states = np.array([[_value(getattr(v, k)) for k in ("x", "y", "z", "x_dot", "y_dot", "z_dot")] for v in vectors])
    covariances = {}
    for matrix in segment.data.covariance_matrix:
        full = np.zeros((6, 6))
        for key, (i, j) in zip(COVARIANCE_KEYS, LOWER_TRIANGLE):
            full[i, j] = full[j, i] = _value(getattr(matrix, key))
        index = tags.index(matrix.epoch) if matrix.epoch in tags else -1
        covariances[index] = full
    return tags, seconds, states, covariances


def read_oem(path) -> list[Ephemeris]:
    """Every object of an OEM file, its segments joined in order (a repeated boundary line kept once). Problems
    (malformed file, unreadable tags, epochs not increasing, an unsupported time system) raise
    ExchangeFileError naming the file."""
    message = library.read_message(path, "OEM")
    if not message.body.segment or not any(seg.data.state_vector for seg in message.body.segment):
        raise ExchangeFileError(f"{path}: malformed CCSDS message (no segment with state lines: META_START ... "
                                "META_STOP, then epoch x y z vx vy vz lines)")
    by_object: dict[str, list] = {}
    for segment in message.body.segment:
        by_object.setdefault(segment.metadata.object_name, []).append(segment)
    out = []
    for name, segments in by_object.items():
        first = segments[0].metadata
        tags, seconds, states, covariances = [], [], [], {}
        for segment in segments:
            meta = segment.metadata
            if (meta.ref_frame, meta.center_name, meta.time_system) != (first.ref_frame, first.center_name,
                                                                        first.time_system):
                raise ExchangeFileError(f"{path}: object {name!r}: segments in different frames or time systems")
            seg_tags, seg_seconds, seg_states, seg_cov = _segment_arrays(path, segment)
            keep = seg_seconds > seconds[-1] if seconds else np.ones(len(seg_tags), dtype=bool)
            covariances.update({len(tags) + int(np.count_nonzero(keep[:i])): c for i, c in seg_cov.items() if i >= 0})
            tags += [t for t, k in zip(seg_tags, keep) if k]
            seconds += list(seg_seconds[keep])
            states.append(seg_states[keep])
        seconds = np.array(seconds)
        if np.any(np.diff(seconds) <= 0):
            raise ExchangeFileError(f"{path}: object {name!r}: epochs are not increasing")
        degree = first.interpolation_degree
        out.append(Ephemeris(name, first.object_id, first.center_name, first.ref_frame, first.time_system, tags,
                             seconds, np.vstack(states), (first.interpolation or "LAGRANGE").upper(),
                             int(degree) if degree is not None else 7, covariances, tuple(first.comment)))
    return out


__all__ = ["Ephemeris", "oem_message", "read_oem"]
