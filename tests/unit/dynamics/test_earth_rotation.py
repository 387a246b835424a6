"""Time scales and the Earth's orientation (003 item 4, issue 24): DSN stations on a dated Earth (ERFA's
IAU 2006/2000A CIO-based transformation, UT1 and polar motion from the IERS file astropy-iers-data ships)
against skyfield's wgs84 topos given the same IERS file: positions within 1 cm (measured: 0.16 mm),
elevations within 0.01 deg. Epochs past the IERS predictions run by the stated rule (held values)."""

from datetime import datetime, timedelta, timezone

import numpy as np
import pytest

from liaison_cli.dynamics import iers_eop
from liaison_cli.dynamics.earth_rotation import cip_xys, elevation_deg, itrf_to_gcrf_many, station_gcrf
from liaison_cli.dynamics.ephemeris import geocentric_state, load_window
from liaison_cli.dynamics.iers_eop import beyond_table_note, eop_at, ut1_minus_utc_s
from liaison_cli.dynamics.timescales import (
    J2000_JD,
    beyond_leap_seconds_note,
    tai_minus_utc_s,
    utc_to_tdb_seconds,
    utc_to_tt_two_part,
)

skyfield = pytest.importorskip("skyfield.api")

DSN = {"Goldstone": (35.4267, -116.8900, 1000.0), "Madrid": (40.4314, -4.2481, 850.0),
       "Canberra": (-35.4014, 148.9817, 680.0)}
# The missions' dates, one the skyfield-data table did not reach (2026-12-01), one inside the predictions.
DATES = (datetime(1997, 10, 15, 8, 43), datetime(2003, 6, 10, 17, 58, 47), datetime(2011, 11, 26, 15, 2),
         datetime(2011, 12, 2, 3, 30), datetime(2026, 12, 1), datetime(2027, 6, 15, 12, 0))


@pytest.fixture(scope="module")
def sky():
    """skyfield's timescale and polar motion built from the same IERS file (where skyfield has data)."""
    from astropy_iers_data import IERS_A_FILE
    from skyfield.data import iers
    from skyfield.timelib import Timescale

    with open(IERS_A_FILE, "rb") as handle:
        mjd, dut1 = iers.parse_dut1_from_finals_all(handle)
    daily_tt, daily_delta_t, leap_dates, leap_offsets = iers.build_timescale_arrays(mjd, dut1)
    ts = Timescale((daily_tt, daily_delta_t), leap_dates, leap_offsets)
    with open(IERS_A_FILE, "rb") as handle:
        iers.install_polar_motion_table(ts, iers.parse_x_y_dut1_from_finals_all(handle))
    return ts


def _at(ts, date):
    return ts.utc(date.year, date.month, date.day, date.hour, date.minute, date.second + date.microsecond * 1e-6)


@pytest.mark.parametrize("date", DATES)
def test_dsn_stations_agree_with_skyfield(sky, date):
    t = _at(sky, date)
    for name, (lat, lon, height) in DSN.items():
        r, v, _ = station_gcrf(lat, lon, height, date)
        ref = skyfield.wgs84.latlon(lat, lon, elevation_m=height).at(t)
        assert np.linalg.norm(r - ref.position.km) * 1e3 < 0.01, name  # measured: 0.16 mm
        assert np.linalg.norm(v - ref.velocity.km_per_s) < 1e-6, name  # 1 mm/s


@pytest.mark.parametrize("date", DATES[:4])
def test_moon_elevation_agrees_with_skyfield(sky, date):
    """The Moon's geometric elevation from each DSN site (our DE421 reader + our Earth rotation) against
    skyfield's altaz of the same geometric vector: within 0.01 deg."""
    from liaison_cli.dynamics.ephemeris import de421_path

    eph = skyfield.load_file(de421_path())
    t = _at(sky, date)
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


def test_the_hourly_cip_grid_matches_direct_evaluation():
    """X, Y, s interpolated from the hourly grid against erfa.xys06a at each epoch: below 3e-11 rad
    (0.2 mm on the Earth's surface; measured 1.9e-11) over 10 days of 1,000 s epochs."""
    import erfa

    moments = [datetime(2026, 12, 1) + timedelta(seconds=1000.0 * k + 17.3) for k in range(865)]
    _, (tt1, tt2) = utc_to_tt_two_part(moments)
    direct = erfa.xys06a(np.full(len(moments), J2000_JD), (tt1 - J2000_JD) + tt2)
    for ours, reference in zip(cip_xys(tt1, tt2), direct):
        assert np.max(np.abs(ours - reference)) < 3e-11


def test_the_leap_seconds_come_from_the_iers_file():
    assert tai_minus_utc_s(datetime(2016, 12, 31)) == 36
    assert tai_minus_utc_s(datetime(2017, 1, 1)) == 37
    assert tai_minus_utc_s(datetime(2035, 1, 1)) == 37  # held past the file's expiry (no further leap second)


def test_a_2035_epoch_runs_by_the_stated_rule():
    """Past the IERS predictions: UT1 - UTC and polar motion held at the last predicted values, TAI - UTC at
    its last value; the rotation stays a rotation and the notes say what was assumed."""
    late = datetime(2035, 3, 1, 6, 0, tzinfo=timezone.utc)
    end = iers_eop.last_day()
    assert late > end
    held, at_end = eop_at([late]), eop_at([end])
    assert all(a[0] == b[0] for a, b in zip(held, at_end))
    rotation = itrf_to_gcrf_many([late, late + timedelta(hours=6)])
    assert np.allclose(rotation @ np.transpose(rotation, (0, 2, 1)), np.eye(3), atol=1e-14)
    r, _, _ = station_gcrf(*DSN["Goldstone"], late)
    assert abs(np.linalg.norm(r) - 6372.0) < 10.0
    assert "held at" in beyond_table_note(late) and "2035-03-01" in beyond_table_note(late)
    assert "TAI - UTC held at 37 s" in beyond_leap_seconds_note(late)
    assert beyond_table_note(datetime(2026, 12, 1)) is None and beyond_leap_seconds_note(datetime(2026, 12, 1)) is None


def test_an_epoch_with_a_utc_offset_is_converted():
    from liaison_cli.scenario.participants import EphemerisSpec

    local = EphemerisSpec(epoch_utc="2026-12-01T05:00:00+05:00").epoch()
    assert local == datetime(2026, 12, 1, tzinfo=timezone.utc)
    assert EphemerisSpec(epoch_utc="2026-12-01T00:00:00Z").epoch() == local
    assert EphemerisSpec(epoch_utc="2026-12-01T00:00:00").epoch() == local


DATED_2035 = """
name: late_epoch
duration_days: 2
dynamics: ephemeris
ephemeris: {epoch_utc: "2035-03-01T06:00:00+01:00"}
spacecraft:
  - {name: Cislunar, orbit: icrf_state, state_km: [20596.04161, 201898.7866, 87521.69929, -0.1714039415, 1.559312361, 0.6759113513]}
ground_stations:
  - {name: Goldstone, latitude_deg: 35.4267, longitude_deg: -116.89, altitude_m: 1000, elevation_mask_deg: 10}
links:
  - {receiver: Goldstone, transponder: Cislunar, observables: [range, range_rate]}
measurement: {interval_s: 1000, light_time: false}
noise: {sigma_m: 10.0, range_rate_sigma_m_s: 0.0005}
monte_carlo: {runs: 1, seed: 2035}
"""


def test_a_dated_scenario_in_2035_runs_end_to_end_with_one_note_per_rule(tmp_path):
    """The bug of issue 24: a dated scenario past the IERS tables ended in a traceback. Now it runs, and the
    rule it runs by is printed once per table, as a note (the epoch's +01:00 converted: ends 2035-03-03)."""
    from tests.conftest import run_cli, stderr_lines

    path = tmp_path / "late.yaml"
    path.write_text(DATED_2035)
    proc = run_cli("run", path, "--output", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    notes = [line for line in stderr_lines(proc.stderr) if line.startswith("note:")]
    assert len(notes) == 2 and "leap-second" in notes[0] and "Earth orientation predictions" in notes[1], notes
    assert "2035-03-03" in notes[0] and "1/1 runs ok" in proc.stdout
