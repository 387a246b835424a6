"""Calendar UTC -> TDB seconds past J2000, the time argument of the ephemeris dynamics.

Steps (each stated, each tested against skyfield):
- UTC calendar -> seconds since 2000-01-01 12:00 UTC counting every day as 86,400 s;
- + (TAI - UTC): the leap-second table below (IERS Bulletin C; it ends with 2017-01-01, 37 s, and holds
  while the IERS announces no new leap second);
- TT = TAI + 32.184 s, so TT seconds past J2000 (2000-01-01 12:00 TT) follow;
- TDB - TT = 0.001657 sin g + 0.000014 sin 2g s, g = 357.53 deg + 0.98560028 deg x (days of TT past
  J2000) (the Explanatory Supplement's two-term series; ~30 us, i.e. ~3 cm of lunar motion).
Dates before 1972 (no leap-second table) are refused.
"""

import math
from datetime import datetime, timezone

# (first UTC day it applies, TAI - UTC in s)
LEAP_SECONDS = (
    ((1972, 1, 1), 10), ((1972, 7, 1), 11), ((1973, 1, 1), 12), ((1974, 1, 1), 13), ((1975, 1, 1), 14),
    ((1976, 1, 1), 15), ((1977, 1, 1), 16), ((1978, 1, 1), 17), ((1979, 1, 1), 18), ((1980, 1, 1), 19),
    ((1981, 7, 1), 20), ((1982, 7, 1), 21), ((1983, 7, 1), 22), ((1985, 7, 1), 23), ((1988, 1, 1), 24),
    ((1990, 1, 1), 25), ((1991, 1, 1), 26), ((1992, 7, 1), 27), ((1993, 7, 1), 28), ((1994, 7, 1), 29),
    ((1996, 1, 1), 30), ((1997, 7, 1), 31), ((1999, 1, 1), 32), ((2006, 1, 1), 33), ((2009, 1, 1), 34),
    ((2012, 7, 1), 35), ((2015, 7, 1), 36), ((2017, 1, 1), 37),
)
TT_MINUS_TAI_S = 32.184
J2000_UTC = datetime(2000, 1, 1, 12, 0, 0, tzinfo=timezone.utc)


def tai_minus_utc_s(moment: datetime) -> int:
    """Leap seconds in force at a UTC moment (timezone-aware or naive UTC)."""
    day = (moment.year, moment.month, moment.day)
    if day < LEAP_SECONDS[0][0]:
        raise ValueError(f"{moment.date()} is before 1972: no leap-second table for it")
    return max(offset for start, offset in LEAP_SECONDS if start <= day)


def utc_to_tt_seconds(moment: datetime) -> float:
    """TT seconds past J2000 of a UTC moment."""
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    utc_seconds = (moment - J2000_UTC).total_seconds()
    return utc_seconds + tai_minus_utc_s(moment) + TT_MINUS_TAI_S


def tdb_minus_tt_s(tt_seconds: float) -> float:
    g = math.radians(357.53 + 0.98560028 * tt_seconds / 86400.0)
    return 0.001657 * math.sin(g) + 0.000014 * math.sin(2.0 * g)


def utc_to_tdb_seconds(moment: datetime) -> float:
    """TDB seconds past J2000 (the ephemeris time argument) of a UTC moment."""
    tt = utc_to_tt_seconds(moment)
    return tt + tdb_minus_tt_s(tt)
