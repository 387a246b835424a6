"""003's three departures (Cassini, MER-A, MSL) as data, and their launch targets derived on DE421.

Published C3 / DLA / RLA values for these launches were not at hand offline, so each target is derived
from published dates instead: the excess velocity of the single-revolution Lambert arc about the Sun
from the Earth at injection to the mission's first target body at its encounter (DE421 positions of the
Earth and of the target system's barycentre; planets' gravity and the B-plane aim point neglected, a
patched-conic estimate good to a few tenths of a km^2/s^2 in C3 and about a degree in the asymptote).

Dates (UTC) and their sources:
- 003 Table 1: the start of each 9-day arc (`start_utc`).
- Cassini: liftoff 1997-10-15 08:43:00 (NASA release, 15 Oct 1997: 4:43 a.m. EDT), separation 42 min 40 s
  later; first Venus flyby 1998-04-26 13:52:14 Earth-received (JPL release, 29 Apr 1998: 6:52:14 PDT,
  7 min one-way light time), so about 13:45 at Venus.
- MER-A (Spirit): liftoff 2003-06-10 17:58:46.773, separation T+36 min 40 s, 167 km parking orbit
  (Spaceflight Now and SpaceRef, 10 Jun 2003); Mars landing 2004-01-04 04:35 (JPL status, 29 Dec 2003).
- MSL: liftoff 2011-11-26 15:02:00 (JPL: 10:02 a.m. EST), separation about 44 min later (ULA release,
  21 Nov 2011); Mars landing 2012-08-06 05:31 Earth-received (JPL status, 28 Jul 2012: 10:31 p.m. PDT).
Periapsis (the impulsive injection) is put at separation: 003's arc starts 602.9 s (Cassini) and 372.4 s
(MSL) after it. MER-A's arc starts 244 s before the reported separation, after the third stage's burn;
there the arc starts at periapsis. Parking orbits: 167 km for MER-A (published); 185 km assumed for the
other two. The plane: a Cape Canaveral due-east parking orbit, inclination 28.5 deg (or |DLA| if larger).
"""

from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

import numpy as np

from liaison_cli.dynamics.constants import OBLIQUITY_J2000_DEG, WGS84_EQUATORIAL_RADIUS_KM
from liaison_cli.dynamics.ephemeris import BODY_SUN, GM_KM3_S2, geocentric_state, load_window
from liaison_cli.dynamics.timescales import utc_to_tdb_seconds
from liaison_cli.orbits.departure import asymptote_angles_deg

CAPE_LATITUDE_DEG = 28.5


def _utc(text: str) -> datetime:
    return datetime.fromisoformat(text).replace(tzinfo=timezone.utc)


@dataclass(frozen=True)
class DepartureMission:
    name: str
    start_utc: str  # 003 Table 1
    separation_utc: str  # injection taken at periapsis here
    target_body: int  # our body code (DE421 system barycentre)
    encounter_utc: str
    parking_altitude_km: float

    def start_utc_datetime(self) -> datetime:
        return _utc(self.start_utc)

    def time_from_periapsis_s(self) -> float:
        """At 003's start: since separation, or 0 if the arc starts before it (MER-A)."""
        return max((_utc(self.start_utc) - _utc(self.separation_utc)).total_seconds(), 0.0)


DEPARTURE_MISSIONS = {
    "cassini": DepartureMission("cassini", "1997-10-15T09:35:42.8824", "1997-10-15T09:25:40", 2,
                                "1998-04-26T13:45:14", 185.0),
    "mer_a": DepartureMission("mer_a", "2003-06-10T18:31:23.184", "2003-06-10T18:35:26.773", 4,
                              "2004-01-04T04:35:00", 167.0),
    "msl": DepartureMission("msl", "2011-11-26T15:52:12.383", "2011-11-26T15:46:00", 4,
                            "2012-08-06T05:31:00", 185.0),
}


def departure_mission_names() -> list[str]:
    return list(DEPARTURE_MISSIONS)


def _heliocentric(body: int, t_tdb_s: float) -> np.ndarray:
    """ICRF state of a body code relative to the Sun (the Earth for body 399)."""
    w = load_window(t_tdb_s, t_tdb_s, margin_s=0.0)
    sun = geocentric_state(w.coeffs, w.start_s, w.interval_s, w.n_records, BODY_SUN, t_tdb_s)
    if body == 399:
        return -sun
    return geocentric_state(w.coeffs, w.start_s, w.interval_s, w.n_records, body, t_tdb_s) - sun


def derived_launch_targets(mission: DepartureMission) -> tuple[float, float, float]:
    """(C3 km^2/s^2, DLA deg, RLA deg) of the Lambert arc from the Earth at injection to the first target."""
    from liaison_cli.orbits.lambert import lambert  # scipy.optimize: ~0.9 s that reading a mission's dates need not pay

    t0 = utc_to_tdb_seconds(_utc(mission.start_utc) - timedelta(seconds=mission.time_from_periapsis_s()))
    t1 = utc_to_tdb_seconds(_utc(mission.encounter_utc))
    earth = _heliocentric(399, t0)
    target = _heliocentric(mission.target_body, t1)
    eps = np.radians(OBLIQUITY_J2000_DEG)
    v1, _ = lambert(earth[:3], target[:3], t1 - t0, GM_KM3_S2[10], prograde_normal=(0.0, -np.sin(eps), np.cos(eps)))
    return asymptote_angles_deg(v1 - earth[3:])


def parking_inclination_deg(dla_deg: float) -> float:
    return max(CAPE_LATITUDE_DEG, abs(dla_deg) + 1e-9)


def periapsis_radius_km(altitude_km: float) -> float:
    return WGS84_EQUATORIAL_RADIUS_KM + altitude_km
