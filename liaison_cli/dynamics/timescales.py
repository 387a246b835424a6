"""Calendar UTC -> TAI -> TT -> TDB through ERFA (pyerfa), with the leap seconds of the IERS file that
astropy-iers-data ships (Leap_Second.dat), and TDB seconds past J2000: the time argument of the ephemeris.

- UTC -> TAI: erfa.utctai (TAI - UTC from the leap-second table; ERFA's own table is extended with the
  IERS file's entries, so a leap second announced after pyerfa's release is known);
- TAI -> TT: erfa.taitt (+32.184 s);
- TT -> TDB: erfa.dtdb at the geocentre (Fairhead & Bretagnon series, ~ns; the topocentric terms, < 2 us,
  are left out as every spacecraft is propagated in geocentric coordinates).

Beyond the tables (a planning tool is used for dates decades ahead): after the leap-second file's expiry
date no further leap second is assumed, so TAI - UTC stays at its last value (37 s since 2017). Truth and
filter share this clock, so a simulation stays self-consistent; a leap second announced later would shift
real UTC by 1 s against ours. `beyond_tables_note` says this in one sentence for a span that needs it.
Dates before 1972 (no leap-second table) are refused.
"""

import math
import warnings
from datetime import datetime, timezone
from functools import lru_cache

import numpy as np

from liaison_cli.dynamics.constants import J2000_JD

J2000_UTC = datetime(2000, 1, 1, 12, 0, 0, tzinfo=timezone.utc)
FIRST_LEAP_TABLE_DAY = (1972, 1, 1)


def as_utc(moment: datetime) -> datetime:
    """A timezone-aware UTC moment: a naive one is read as UTC, an aware one converted (+05:00 -> 5 h earlier)."""
    if moment.tzinfo is None:
        return moment.replace(tzinfo=timezone.utc)
    return moment.astimezone(timezone.utc)


@lru_cache(maxsize=1)
def leap_second_table() -> tuple[tuple[tuple[int, int, int], int], ...]:
    """((first UTC day, TAI - UTC s), ...) from astropy-iers-data's Leap_Second.dat, and installs them into
    ERFA (erfa.leap_seconds.update), so erfa.utctai and erfa.dat know every leap second the file lists."""
    import erfa
    from astropy_iers_data import IERS_LEAP_SECOND_FILE

    rows = []
    with open(IERS_LEAP_SECOND_FILE, encoding="ascii") as handle:
        for line in handle:
            if line.startswith("#") or not line.strip():
                continue
            _, day, month, year, offset = line.split()
            rows.append(((int(year), int(month), int(day)), int(offset)))
    table = np.array([(y, m, s) for (y, m, _), s in rows], dtype=[("year", "i4"), ("month", "i4"), ("tai_utc", "f8")])
    erfa.leap_seconds.update(table)
    return tuple(rows)


@lru_cache(maxsize=1)
def leap_seconds_expiry() -> datetime:
    """The date until which the IERS leap-second file is valid ('File expires on 28 June 2027')."""
    from astropy_iers_data import IERS_LEAP_SECOND_FILE

    with open(IERS_LEAP_SECOND_FILE, encoding="ascii") as handle:
        for line in handle:
            if "File expires on" in line:
                text = line.split("File expires on", 1)[1].strip()
                return datetime.strptime(text, "%d %B %Y").replace(tzinfo=timezone.utc)
    raise ValueError(f"{IERS_LEAP_SECOND_FILE}: no expiry line")


def _erfa():
    """pyerfa with the IERS leap seconds installed."""
    import erfa

    leap_second_table()
    return erfa


def _utc_two_part(moments) -> tuple[np.ndarray, np.ndarray]:
    """UTC quasi-Julian dates (two parts, ERFA's convention: day + fraction) of UTC moments."""
    erfa = _erfa()
    utc = [as_utc(m) for m in moments]
    if any((m.year, m.month, m.day) < FIRST_LEAP_TABLE_DAY for m in utc):
        first = min(utc)
        raise ValueError(f"{first.date()} is before 1972: no leap-second table for it")
    seconds = [m.second + m.microsecond * 1e-6 for m in utc]
    with warnings.catch_warnings():  # 'dubious year' past pyerfa's release: the module docstring's rule
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        d1, d2 = erfa.dtf2d("UTC", [m.year for m in utc], [m.month for m in utc], [m.day for m in utc],
                            [m.hour for m in utc], [m.minute for m in utc], seconds)
    return np.atleast_1d(d1), np.atleast_1d(d2)


def utc_to_tt_two_part(moments) -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """((utc1, utc2), (tt1, tt2)): the UTC and TT two-part Julian dates (m,) of UTC moments."""
    erfa = _erfa()
    utc1, utc2 = _utc_two_part(moments)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        tai1, tai2 = erfa.utctai(utc1, utc2)
    tt1, tt2 = erfa.taitt(tai1, tai2)
    return (utc1, utc2), (tt1, tt2)


def tai_minus_utc_s(moment: datetime) -> int:
    """Leap seconds in force at a UTC moment (timezone-aware or naive UTC)."""
    erfa = _erfa()
    moment = as_utc(moment)
    if (moment.year, moment.month, moment.day) < FIRST_LEAP_TABLE_DAY:
        raise ValueError(f"{moment.date()} is before 1972: no leap-second table for it")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        return int(round(float(erfa.dat(moment.year, moment.month, moment.day, 0.0))))


def utc_to_tt_seconds_many(moments) -> np.ndarray:
    """TT seconds past J2000 (m,) of UTC moments."""
    _, (tt1, tt2) = utc_to_tt_two_part(moments)
    return ((tt1 - J2000_JD) + tt2) * 86400.0


def utc_to_tt_seconds(moment: datetime) -> float:
    """TT seconds past J2000 of a UTC moment."""
    return float(utc_to_tt_seconds_many([moment])[0])


def tdb_minus_tt_s(tt_seconds: float) -> float:
    """TDB - TT (s) at the geocentre at TT seconds past J2000 (erfa.dtdb)."""
    erfa = _erfa()
    days = tt_seconds / 86400.0
    fraction_of_day = math.fmod(days + 0.5, 1.0)
    return float(erfa.dtdb(J2000_JD, days, fraction_of_day, 0.0, 0.0, 0.0))


def utc_to_tdb_seconds(moment: datetime) -> float:
    """TDB seconds past J2000 (the ephemeris time argument) of a UTC moment."""
    tt = utc_to_tt_seconds(moment)
    return tt + tdb_minus_tt_s(tt)


def beyond_leap_seconds_note(last_moment: datetime) -> str | None:
    """One sentence when `last_moment` lies past the leap-second file's expiry, else None."""
    expiry = leap_seconds_expiry()
    if as_utc(last_moment) <= expiry:
        return None
    last = leap_second_table()[-1]
    return (f"{as_utc(last_moment):%Y-%m-%d} is past the IERS leap-second file's expiry ({expiry:%Y-%m-%d}): "
            f"no later leap second is assumed (TAI - UTC held at {last[1]} s)")
