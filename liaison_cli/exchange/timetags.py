"""CCSDS time tags <-> seconds. Dated scenarios tag epochs in TDB (their grid is uniform in TDB seconds past
J2000, the ephemeris argument); UTC and TT tags are read too. Undated (CRTBP) scenarios tag epochs in MET,
mission elapsed time from the scenario's t0, written as a day-of-year date of year 0000: 0000-001T00:00:00 is t0
(a CRTBP has no calendar date; see docs/exchange.md)."""

import re
from datetime import datetime, timedelta, timezone

import numpy as np

from liaison_cli.dynamics.timescales import tdb_minus_tt_s, utc_to_tt_seconds_many

J2000_CALENDAR = datetime(2000, 1, 1, 12, 0, 0)  # J2000 as a calendar reading of the TDB (or TT) clock
MET_ORIGIN = datetime(1, 1, 1)  # stands in for year 0000 (datetime has no year 0); only differences matter
READABLE_TIME_SYSTEMS = ("TDB", "UTC", "TT", "MET")
_TAG = re.compile(r"^\s*(\d{4})-(?:(\d{2})-(\d{2})|(\d{3}))T(\d{2}):(\d{2}):(\d{2}(?:\.\d*)?)\s*Z?\s*$")


def _split(tag: str) -> tuple[int, int, float]:
    """(year, day of year, seconds of day) of a CCSDS ASCII time tag (calendar or day-of-year form)."""
    match = _TAG.match(tag)
    if not match:
        raise ValueError(f"time tag {tag!r} is not YYYY-MM-DDThh:mm:ss[.d] or YYYY-DDDThh:mm:ss[.d]")
    year, month, day, doy, hour, minute, second = match.groups()
    year = int(year)
    if doy is not None:
        day_of_year = int(doy)
    else:
        calendar_year = year if year > 0 else 2000  # year 0000 is a leap year, as 2000
        day_of_year = (datetime(calendar_year, int(month), int(day)) - datetime(calendar_year, 1, 1)).days + 1
    return year, day_of_year, int(hour) * 3600.0 + int(minute) * 60.0 + float(second)


def _days_from_j2000(year: int, day_of_year: int) -> int:
    return (datetime(year, 1, 1) + timedelta(days=day_of_year - 1) - J2000_CALENDAR.replace(hour=0)).days


def tags_to_seconds(tags, time_system: str) -> np.ndarray:
    """TDB seconds past J2000 of dated tags (TDB, TT or UTC), or MET seconds from t0 (MET)."""
    parts = [_split(t) for t in tags]
    if time_system == "MET":
        if any(year != 0 for year, _, _ in parts):
            raise ValueError("MET tags are read as 0000-DDDThh:mm:ss (0000-001T00:00:00 = t0)")
        return np.array([(doy - 1) * 86400.0 + sod for _, doy, sod in parts])
    if time_system in ("TDB", "TT"):
        seconds = np.array([_days_from_j2000(y, d) * 86400.0 + sod - 43200.0 for y, d, sod in parts])
        if time_system == "TT":
            seconds = seconds + np.array([tdb_minus_tt_s(s) for s in seconds])
        return seconds
    if time_system == "UTC":
        whole = [datetime(y, 1, 1, tzinfo=timezone.utc) + timedelta(days=d - 1, seconds=int(s)) for y, d, s in parts]
        fraction = np.array([s - int(s) for _, _, s in parts])
        tt = utc_to_tt_seconds_many(whole) + fraction
        return tt + np.array([tdb_minus_tt_s(s) for s in tt])
    raise ValueError(f"time system {time_system!r} is not supported; allowed: {', '.join(READABLE_TIME_SYSTEMS)}")


def _format(origin: datetime, seconds: float, day_of_year: bool, year0: bool) -> str:
    whole = int(np.floor(seconds))
    micro = int(round((seconds - whole) * 1e6))
    if micro == 1_000_000:
        whole, micro = whole + 1, 0
    moment = origin + timedelta(seconds=whole)
    clock = f"{moment.hour:02d}:{moment.minute:02d}:{moment.second:02d}.{micro:06d}"
    if day_of_year:
        year = 0 if year0 else moment.year
        return f"{year:04d}-{moment.timetuple().tm_yday:03d}T{clock}"
    return f"{moment.year:04d}-{moment.month:02d}-{moment.day:02d}T{clock}"


def tdb_tags(tdb_seconds) -> list[str]:
    """TDB calendar tags (microseconds) of TDB seconds past J2000."""
    return [_format(J2000_CALENDAR, float(s), False, False) for s in tdb_seconds]


def met_tags(elapsed_s) -> list[str]:
    """MET tags of seconds from t0: 0000-DDDThh:mm:ss.ffffff, day 001 the first (under 366 days)."""
    if np.any(np.asarray(elapsed_s) >= 366 * 86400.0):
        raise ValueError("MET tags of year 0000 cover 366 days")
    return [_format(MET_ORIGIN, float(s), True, True) for s in elapsed_s]
