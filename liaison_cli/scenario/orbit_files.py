"""A dated spacecraft's truth from an OEM, or its initial state from an OPM (scenario key orbit: {oem: FILE} /
{opm: FILE}): the file's states in geocentric ICRF (from ICRF, GCRF or EME2000; Earth-centred), on the
scenario's TDB grid, in the estimators' scaled units. A CRTBP spacecraft's truth from an OEM in liaison's
rotating frame with MET tags (its own export read back: crtbp_oem_truth_lu). Every problem is one line naming
the file."""

import numpy as np

from liaison_cli.dynamics.ephemeris_model import SCALE
from liaison_cli.errors import ExchangeFileError
from liaison_cli.exchange.frames import (CRTBP_CENTRE, CRTBP_FRAME, CRTBP_KM_PER_SCALED, DATED_FRAMES, EARTH_CENTRES,
                                         to_icrf)
from liaison_cli.exchange.interpolation import METHODS, interpolate_states

DATED_TIME_SYSTEMS = ("TDB", "TT", "UTC")
EPOCH_TOLERANCE_S = 1e-3  # an OPM epoch this close to the scenario epoch is the scenario epoch


def _check_frame(path, centre: str, frame: str, time_system: str) -> None:
    if centre.upper() not in EARTH_CENTRES:
        raise ExchangeFileError(f"{path}: CENTER_NAME = {centre}: not supported; allowed: {', '.join(EARTH_CENTRES)}")
    if frame.upper() not in DATED_FRAMES:
        raise ExchangeFileError(f"{path}: REF_FRAME = {frame}: not supported for a dated scenario; allowed: "
                                f"{', '.join(DATED_FRAMES)}")
    if time_system not in DATED_TIME_SYSTEMS:
        raise ExchangeFileError(f"{path}: TIME_SYSTEM = {time_system}: not supported for a dated scenario; allowed: "
                                f"{', '.join(DATED_TIME_SYSTEMS)}")


def _pick(path, records, spacecraft):
    wanted = spacecraft.orbit_file.object_name
    names = [r.object_name for r in records]
    if wanted is None and len(records) == 1:
        return records[0]
    wanted = wanted or spacecraft.name
    if wanted not in names:
        raise ExchangeFileError(f"{path}: no object {wanted!r} (spacecraft {spacecraft.name!r}); the file holds "
                                f"{', '.join(names)}; name one with orbit: {{object_name: ...}}")
    return records[names.index(wanted)]


# What a malformed file that the CCSDS reader accepted can still raise while we use its contents (a zero or
# NaN state, a missing component, a degree out of range, a date past datetime's years): one line, not a
# traceback (issue 35).
_MALFORMED = (ValueError, TypeError, AttributeError, IndexError, KeyError, ZeroDivisionError, OverflowError)


def _one_line(kind: str):
    """Decorator: the wrapped reader's errors from a malformed file become one ExchangeFileError line naming the
    file (the spacecraft's orbit_file)."""
    def wrap(read):
        def guarded(spacecraft, *args):
            path = getattr(spacecraft.orbit_file, kind)
            try:
                return read(spacecraft, *args)
            except _MALFORMED as exc:
                raise ExchangeFileError(f"{path}: malformed {kind.upper()} ({type(exc).__name__}: "
                                        f"{str(exc)[:160]})") from None
        guarded.__doc__ = read.__doc__
        return guarded
    return wrap


def _finite_states(path, states_km) -> None:
    states_km = np.asarray(states_km, dtype=float)
    if not np.all(np.isfinite(states_km)):
        raise ExchangeFileError(f"{path}: a state holds NaN or infinity; allowed: finite numbers")
    if np.any(np.linalg.norm(states_km[..., :3], axis=-1) == 0.0):
        raise ExchangeFileError(f"{path}: a state is at the centre (position 0 km); allowed: a position off it")


def _oem_states_km(spacecraft, check_frame, at_s: np.ndarray):
    """(m, 6) states (km, km/s) of the spacecraft's OEM at the file's own seconds `at_s` (TDB s past J2000, or MET
    s), interpolated as the file says, and its frame; check_frame(path, centre, frame, time system) first."""
    from liaison_cli.exchange.oem import read_oem

    path = spacecraft.orbit_file.oem
    ephemeris = _pick(path, read_oem(path), spacecraft)
    check_frame(path, ephemeris.centre, ephemeris.frame, ephemeris.time_system)
    _finite_states(path, ephemeris.states_km)
    if ephemeris.interpolation == "LAGRANGE" and not 1 <= ephemeris.degree <= 20:
        raise ExchangeFileError(f"{path}: INTERPOLATION_DEGREE = {ephemeris.degree}; allowed: 1 to 20")
    if ephemeris.interpolation not in METHODS:
        raise ExchangeFileError(f"{path}: INTERPOLATION = {ephemeris.interpolation}: not supported; allowed: "
                                f"{', '.join(METHODS)}")
    needed = ephemeris.degree + 1 if ephemeris.interpolation == "LAGRANGE" else 2
    if len(ephemeris.seconds) < needed:
        raise ExchangeFileError(f"{path}: {len(ephemeris.seconds)} state lines, {ephemeris.interpolation} of "
                                f"degree {ephemeris.degree} needs {needed}")
    first, last = ephemeris.seconds[0], ephemeris.seconds[-1]
    if at_s[0] < first - EPOCH_TOLERANCE_S or at_s[-1] > last + EPOCH_TOLERANCE_S:
        raise ExchangeFileError(
            f"{path}: the OEM covers {ephemeris.tags[0]} to {ephemeris.tags[-1]} ({ephemeris.time_system}), not the "
            f"scenario's span ({(at_s[0] - first) / 86400:+.4f} d to {(at_s[-1] - last) / 86400:+.4f} d "
            "from its ends)")
    at_s = np.clip(at_s, first, last)
    states = interpolate_states(ephemeris.seconds, ephemeris.states_km, at_s, ephemeris.interpolation,
                                ephemeris.degree)
    return states, ephemeris.frame.upper()


@_one_line("oem")
def oem_truth_lu(spacecraft, epoch_tdb_s: float, times_s: np.ndarray) -> np.ndarray:
    """(m, 6) scaled geocentric ICRF states at epoch_tdb_s + times_s, interpolated in the spacecraft's OEM."""
    states, frame = _oem_states_km(spacecraft, _check_frame, epoch_tdb_s + np.asarray(times_s, dtype=float))
    return to_icrf(states, frame) / SCALE


def _check_crtbp_frame(path, centre: str, frame: str, time_system: str) -> None:
    """A CRTBP scenario reads liaison's own CRTBP export: the rotating frame, MET tags (t0 = 0000-001T00:00:00)."""
    for key, value, allowed in (("REF_FRAME", frame.upper(), CRTBP_FRAME), ("CENTER_NAME", centre.upper(),
                                                                           CRTBP_CENTRE),
                                ("TIME_SYSTEM", time_system, "MET")):
        if value != allowed:
            raise ExchangeFileError(f"{path}: {key} = {value}: not supported in a CRTBP scenario (dynamics: crtbp); "
                                    f"allowed: {allowed} (REF_FRAME {CRTBP_FRAME}, CENTER_NAME {CRTBP_CENTRE}, "
                                    "TIME_SYSTEM MET: a CRTBP export of liaison); a dated OEM needs dynamics: "
                                    "ephemeris")


@_one_line("oem")
def crtbp_oem_truth_lu(spacecraft, times_s: np.ndarray) -> np.ndarray:
    """(m, 6) states in the CRTBP's scaled rotating frame (LU, VU) at MET times_s, interpolated in the
    spacecraft's OEM: liaison's export of a CRTBP run read back (docs/exchange.md)."""
    states, _ = _oem_states_km(spacecraft, _check_crtbp_frame, np.asarray(times_s, dtype=float))
    return states / CRTBP_KM_PER_SCALED


@_one_line("opm")
def opm_state_lu(spacecraft, epoch_tdb_s: float) -> np.ndarray:
    """(6,) scaled geocentric ICRF state of the spacecraft's OPM, whose epoch must be the scenario's."""
    from liaison_cli.exchange.opm import read_opm

    path = spacecraft.orbit_file.opm
    record = read_opm(path)
    _check_frame(path, record.centre, record.frame, record.time_system)
    _finite_states(path, record.state_km)
    if abs(record.seconds - epoch_tdb_s) > EPOCH_TOLERANCE_S:
        raise ExchangeFileError(f"{path}: EPOCH = {record.tag} ({record.time_system}) is "
                                f"{record.seconds - epoch_tdb_s:+.3f} s from the scenario's epoch; allowed: "
                                f"within {EPOCH_TOLERANCE_S:g} s")
    return to_icrf(record.state_km[None, :], record.frame.upper())[0] / SCALE
