"""003 item 4: DSN stations on a dated Earth (IAU 1976/1980 + GAST on UT1 from the IERS file) against
skyfield's wgs84 topos on the same dates: positions within 20 m (measured: < 1 m), elevation within 0.01 deg."""

from datetime import datetime

import numpy as np
import pytest

from liaison_cli.dynamics.earth_rotation import elevation_deg, station_gcrf, ut1_minus_utc_s
from liaison_cli.dynamics.ephemeris import geocentric_state, load_window
from liaison_cli.dynamics.timescales import utc_to_tdb_seconds

skyfield = pytest.importorskip("skyfield.api")

DSN = {"Goldstone": (35.4267, -116.8900, 1000.0), "Madrid": (40.4314, -4.2481, 850.0),
       "Canberra": (-35.4014, 148.9817, 680.0)}
DATES = (datetime(1997, 10, 15, 8, 43), datetime(2003, 6, 10, 17, 58, 47), datetime(2011, 11, 26, 15, 2),
         datetime(2011, 12, 2, 3, 30))


@pytest.mark.parametrize("date", DATES)
def test_dsn_stations_agree_with_skyfield(date):
    ts = skyfield.load.timescale(builtin=True)
    t = ts.utc(date.year, date.month, date.day, date.hour, date.minute, date.second)
    for name, (lat, lon, height) in DSN.items():
        r, v, _ = station_gcrf(lat, lon, height, date)
        ref = skyfield.wgs84.latlon(lat, lon, elevation_m=height).at(t)
        assert np.linalg.norm(r - ref.position.km) * 1e3 < 20.0, name
        assert np.linalg.norm(v - ref.velocity.km_per_s) < 1e-6, name  # 1 mm/s


@pytest.mark.parametrize("date", DATES)
def test_moon_elevation_agrees_with_skyfield(date):
    """The Moon's geometric elevation from each DSN site (our DE421 reader + our Earth rotation) against
    skyfield's altaz of the same geometric vector: within 0.01 deg."""
    ts = skyfield.load.timescale(builtin=True)
    eph = skyfield.load_file(__import__("liaison_cli.dynamics.ephemeris", fromlist=["de421_path"]).de421_path())
    t = ts.utc(date.year, date.month, date.day, date.hour, date.minute, date.second)
    t_s = utc_to_tdb_seconds(date)
    window = load_window(t_s, t_s + 60.0)
    moon = geocentric_state(window.coeffs, window.start_s, window.interval_s, window.n_records, 301, t_s)[:3]
    for name, (lat, lon, height) in DSN.items():
        r, _, up = station_gcrf(lat, lon, height, date)
        topos = skyfield.wgs84.latlon(lat, lon, elevation_m=height)
        alt, _, _ = (eph["moon"] - (eph["earth"] + topos)).at(t).altaz()
        assert elevation_deg(r, up, moon) == pytest.approx(alt.degrees, abs=0.01), name


def test_ut1_interpolation_steps_over_leap_seconds():
    """UT1 - UTC jumps by +1 s at a leap second; interpolation must not smear it across the day."""
    before, after = ut1_minus_utc_s(datetime(2016, 12, 31, 23, 0)), ut1_minus_utc_s(datetime(2017, 1, 1, 1, 0))
    assert -1.0 < before < 0.0 and 0.0 < after < 1.0 and after - before == pytest.approx(1.0, abs=0.01)
