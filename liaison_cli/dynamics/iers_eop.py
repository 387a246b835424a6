"""Earth orientation parameters (UT1 - UTC, polar motion x_p, y_p) from the IERS `finals2000A.all` file that
astropy-iers-data ships (Bulletin A columns: measured values, then about a year of predictions).

Values are linear between the file's daily rows, except across a leap second, where UT1 - UTC jumps by
+1 s and is interpolated on the continuous side. Beyond the last predicted row (`last_day`) the rule is to
hold the last predicted values: UTC is kept within 0.9 s of UT1 by leap seconds, so a held UT1 - UTC is
never more than ~0.9 s from the real one (~0.4 km of station motion at the equator), and polar motion
stays within its ~0.5" circle (~15 m). Truth and filter share these values, so a simulation stays
self-consistent; `beyond_table_note` says so in one sentence for a span that needs it.
"""

from datetime import datetime
from functools import lru_cache

import numpy as np

from liaison_cli.dynamics.constants import MJD_OF_J2000
from liaison_cli.dynamics.timescales import J2000_UTC, as_utc

ARCSEC_RAD = np.pi / (180.0 * 3600.0)
MJD_OF_J2000_UTC = MJD_OF_J2000  # J2000_UTC's day in the table's count


@lru_cache(maxsize=1)
def eop_table() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(MJD (n,), UT1 - UTC s (n,), x_p arcsec (n,), y_p arcsec (n,)) from finals2000A.all; rows without a
    UT1 - UTC value (the file's empty tail) are skipped."""
    from astropy_iers_data import IERS_A_FILE

    mjd, dut1, xp, yp = [], [], [], []
    with open(IERS_A_FILE, encoding="ascii") as handle:
        for line in handle:
            value = line[58:68].strip()
            if value and line[18:27].strip() and line[37:46].strip():
                mjd.append(float(line[7:15]))
                dut1.append(float(value))
                xp.append(float(line[18:27]))
                yp.append(float(line[37:46]))
    return np.array(mjd), np.array(dut1), np.array(xp), np.array(yp)


def mjd_utc(moments) -> np.ndarray:
    """UTC modified Julian dates (m,) of UTC moments (every day 86,400 s, as the IERS file counts them)."""
    return np.array([(as_utc(m) - J2000_UTC).total_seconds() / 86400.0 + MJD_OF_J2000_UTC for m in moments])


def first_day() -> datetime:
    return _datetime_of_mjd(eop_table()[0][0])


def last_day() -> datetime:
    """The last day the file has a (predicted) value for."""
    return _datetime_of_mjd(eop_table()[0][-1])


def _datetime_of_mjd(mjd: float) -> datetime:
    from datetime import timedelta

    return J2000_UTC + timedelta(days=float(mjd) - MJD_OF_J2000_UTC)


def eop_at(moments) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(UT1 - UTC s, x_p rad, y_p rad), each (m,), at UTC moments, by the module docstring's rule."""
    table_mjd, dut1, xp, yp = eop_table()
    mjd = mjd_utc(moments)
    if np.any(mjd < table_mjd[0]):
        raise ValueError(f"{min(moments):%Y-%m-%d}: before the IERS Earth orientation table "
                         f"({first_day():%Y-%m-%d})")
    held = np.minimum(mjd, table_mjd[-1])
    i = np.clip(np.searchsorted(table_mjd, held, side="right") - 1, 0, table_mjd.size - 2)
    frac = (held - table_mjd[i]) / (table_mjd[i + 1] - table_mjd[i])
    lo, hi = dut1[i], dut1[i + 1]
    hi = np.where(hi - lo > 0.5, hi - 1.0, hi)  # a leap second between the rows
    ut1_utc = lo + frac * (hi - lo)
    x = (xp[i] + frac * (xp[i + 1] - xp[i])) * ARCSEC_RAD
    y = (yp[i] + frac * (yp[i + 1] - yp[i])) * ARCSEC_RAD
    return ut1_utc, x, y


def ut1_minus_utc_s(moment: datetime) -> float:
    return float(eop_at([moment])[0][0])


def beyond_table_note(last_moment: datetime) -> str | None:
    """One sentence when `last_moment` lies past the file's last predicted day, else None."""
    end = last_day()
    if as_utc(last_moment) <= end:
        return None
    ut1_utc, x, y = eop_at([end])
    return (f"{as_utc(last_moment):%Y-%m-%d} is past the IERS Earth orientation predictions (last {end:%Y-%m-%d}): "
            f"UT1 - UTC held at {ut1_utc[0]:+.4f} s and polar motion at ({x[0] / ARCSEC_RAD:.4f}\", "
            f"{y[0] / ARCSEC_RAD:.4f}\"); stations may sit up to ~0.4 km from the real Earth's, truth and filter "
            "alike")
