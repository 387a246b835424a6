"""OPM (CCSDS 502.0-B-3, version 3.0) -> one state: its object, frame, time system, epoch and state (km, km/s),
through ccsds-ndm. Written by tests and other tools; liaison reads it as a spacecraft's initial state."""

from dataclasses import dataclass

import numpy as np

from liaison_cli.errors import ExchangeFileError
from liaison_cli.exchange import library
from liaison_cli.exchange.timetags import READABLE_TIME_SYSTEMS, tags_to_seconds


@dataclass(frozen=True, eq=False)
class StateRecord:
    object_name: str
    centre: str
    frame: str
    time_system: str
    tag: str
    seconds: float
    state_km: np.ndarray


def read_opm(path) -> StateRecord:
    message = library.read_message(path, "OPM")
    segment = message.body.segment
    meta, vector = segment.metadata, segment.data.state_vector
    if meta.time_system not in READABLE_TIME_SYSTEMS:
        raise ExchangeFileError(f"{path}: TIME_SYSTEM = {meta.time_system}: not supported; allowed: "
                                f"{', '.join(READABLE_TIME_SYSTEMS)}")
    try:
        seconds = float(tags_to_seconds([vector.epoch], meta.time_system)[0])
    except ValueError as exc:
        raise ExchangeFileError(f"{path}: {exc}") from None
    state = np.array([float(getattr(vector, k).value) for k in ("x", "y", "z", "x_dot", "y_dot", "z_dot")])
    return StateRecord(meta.object_name, meta.center_name, meta.ref_frame, meta.time_system, vector.epoch, seconds,
                       state)
