"""The Moon's orientation (dynamics.lunar_orientation) against the Moon's observed behaviour: a rotation; the Earth
seen from the Moon wanders within the optical librations about the principal axes' x axis; the pole sits 1.54 deg
from the ecliptic's (Cassini's laws); one turn per sidereal month."""

import math

import numpy as np
import pytest

from liaison_cli.dynamics.ephemeris import BODY_MOON, geocentric_state, load_window
from liaison_cli.dynamics.lunar_orientation import PA_FROM_ME, moon_pa_from_icrf
from liaison_cli.dynamics.timescales import utc_to_tdb_seconds

OBLIQUITY_J2000_DEG = 23.4392911  # the ecliptic's tilt to the ICRF equator (IAU 2006)


@pytest.fixture(scope="module")
def month():
    """TDB seconds of 60 days from 2026-01-01, hourly, and the Moon's geocentric positions (km) at them."""
    from datetime import datetime

    t0 = utc_to_tdb_seconds(datetime(2026, 1, 1))
    times = t0 + np.arange(0.0, 60 * 86400.0, 3600.0)
    window = load_window(times[0], times[-1])
    moon = np.array([geocentric_state(window.coeffs, window.start_s, window.interval_s, window.n_records, BODY_MOON,
                                      t)[:3] for t in times])
    return times, moon


def test_it_is_a_rotation_and_the_principal_axes_sit_near_the_mean_earth_axes():
    for t in (-3e9, 0.0, 8.2e8, 2e9):
        rot = moon_pa_from_icrf(t)
        assert np.allclose(rot @ rot.T, np.eye(3), atol=1e-15) and math.isclose(np.linalg.det(rot), 1.0)
    # DE430's principal axes are 1-2 arcmin off the mean-Earth axes (the angles themselves are data)
    offset_arcsec = math.degrees(math.acos((np.trace(PA_FROM_ME) - 1.0) / 2.0)) * 3600.0
    assert 60.0 < offset_arcsec < 130.0, offset_arcsec


def test_the_earth_seen_from_the_moon_stays_within_the_librations(month):
    """The sub-Earth point's longitude and latitude in the principal axes: the optical librations reach about
    7.9 deg in longitude and 6.9 deg in latitude, and average out near the prime meridian."""
    times, moon = month
    earth_in_pa = np.array([moon_pa_from_icrf(t) @ -r for t, r in zip(times, moon)])
    unit = earth_in_pa / np.linalg.norm(earth_in_pa, axis=1, keepdims=True)
    longitude = np.degrees(np.arctan2(unit[:, 1], unit[:, 0]))
    latitude = np.degrees(np.arcsin(unit[:, 2]))
    assert 5.0 < np.max(np.abs(longitude)) < 8.5 and 5.0 < np.max(np.abs(latitude)) < 7.5
    assert abs(np.mean(longitude)) < 1.0 and abs(np.mean(latitude)) < 1.0


def test_the_pole_keeps_cassinis_tilt_and_the_moon_turns_once_a_sidereal_month(month):
    times, _ = month
    tilt = math.radians(OBLIQUITY_J2000_DEG)
    ecliptic_pole = np.array([0.0, -math.sin(tilt), math.cos(tilt)])
    for t in times[::100]:
        pole = moon_pa_from_icrf(t)[2]  # the PA z axis in ICRF components
        assert abs(math.degrees(math.acos(pole @ ecliptic_pole)) - 1.54) < 0.1
    # the spin rate from the change of the rotation over an hour
    step = 3600.0
    change = moon_pa_from_icrf(times[0] + step) @ moon_pa_from_icrf(times[0]).T
    rate_rad_s = math.acos((np.trace(change) - 1.0) / 2.0) / step
    sidereal_month_d = 27.321661
    assert abs(rate_rad_s / (2.0 * math.pi / (sidereal_month_d * 86400.0)) - 1.0) < 0.03


def test_the_principal_axes_stay_within_20_arcsec_of_de421s_integrated_librations():
    """Against an independent source, DE421's numerically integrated physical librations (the `de421` package, read
    by benchmarks.lunar_orientation), every 7.3 d over 2000-2049: liaison's principal axes (the IAU series, then
    DE430's turn) stay within 20″ (measured: 18.1″ at worst, 153 m at the surface, and 9.4″ RMS, sampled every
    1.37 d), with no mean offset beyond 2″ per axis (measured: 1.4″ at most, the IAU series' own bias and the
    two ephemerides' principal axes, which differ by a fraction of an arcsecond). The IAU mean-Earth axes alone are about 100″ off, reversed turn about 200″: the turn is needed,
    and its sign is right."""
    from benchmarks.lunar_orientation import departures

    times = np.arange(0.0, 50 * 365.25 * 86400.0, 7.3 * 86400.0)
    vectors, _ = departures(times)
    angles = np.linalg.norm(vectors, axis=1)
    assert angles.max() <= 20.0, angles.max()
    assert np.all(np.abs(vectors.mean(axis=0)) <= 2.0), vectors.mean(axis=0)
    without_turn = np.linalg.norm(departures(times, with_pa_turn=False)[0], axis=1)
    assert np.sqrt(np.mean(without_turn**2)) >= 90.0
