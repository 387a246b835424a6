"""Named ground sites: the three Deep Space Network complexes (003: Goldstone, Madrid, Canberra) and two
VLBA antennas (004: Mauna Kea, Owens Valley).

Each site is its 70 m antenna, given as published Earth-fixed Cartesian coordinates (m) and turned into
WGS84 geodetic latitude, longitude and height here, the form a scenario's ground station takes.

Source: J. Astron. Space Sci. 40(2), 79 (2023), Table 1 (DSN antennas allocated to KPLO): DSS 14, 43, 63.
They agree with the IAU Commission 4 list of DSN coordinates (ITRF2005, epoch 2003.0) to 0.07 m (DSS 14)
and 0.11 m (DSS 43), far below the 10 m station noise of 003; tests/unit/measurements/test_dsn_tracking.py keeps that check.
VLBA: NRAO's VLBA Observational Status Summary, Table 1 (WGS84 geodetic, degrees-minutes-seconds, metres).
"""

import numpy as np

from liaison_cli.dynamics.constants import WGS84_EQUATORIAL_RADIUS_KM, WGS84_FLATTENING

# name -> (antenna, x, y, z in metres, Earth-fixed)
DSN_SITES_ECEF_M = {
    "goldstone": ("DSS 14", -2353621.420, -4641341.472, 3677052.318),
    "madrid": ("DSS 63", 4849092.518, -360180.348, 4115109.251),
    "canberra": ("DSS 43", -4460894.917, 2682361.507, -3674748.152),
}


# name -> (antenna, latitude deg, east longitude deg, height m)
VLBA_SITES = {
    "mauna_kea": ("VLBA MK", 19 + 48 / 60 + 4.97 / 3600, -(155 + 27 / 60 + 19.81 / 3600), 3763.0),
    "owens_valley": ("VLBA OV", 37 + 13 / 60 + 53.95 / 3600, -(118 + 16 / 60 + 37.37 / 3600), 1196.0),
}


def dsn_site_names() -> list[str]:
    """Every named site (DSN and VLBA)."""
    return [*DSN_SITES_ECEF_M, *VLBA_SITES]


def ecef_to_geodetic(x_m: float, y_m: float, z_m: float) -> tuple[float, float, float]:
    """WGS84 geodetic latitude (deg), east longitude (deg, -180..180) and height (m) of an Earth-fixed point:
    fixed-point iteration phi = atan2(z + e^2 N(phi) sin(phi), p), which converges to 1e-14 rad in a few
    steps near the surface and holds at the poles; h = p cos(phi) + z sin(phi) - a sqrt(1 - e^2 sin^2 phi)."""
    a_m = WGS84_EQUATORIAL_RADIUS_KM * 1e3
    e2 = WGS84_FLATTENING * (2.0 - WGS84_FLATTENING)
    p = float(np.hypot(x_m, y_m))
    lat = np.arctan2(z_m, p * (1.0 - e2))
    for _ in range(30):
        n = a_m / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
        new = np.arctan2(z_m + e2 * n * np.sin(lat), p)
        done = abs(new - lat) < 1e-14
        lat = new
        if done:
            break
    height = p * np.cos(lat) + z_m * np.sin(lat) - a_m * np.sqrt(1.0 - e2 * np.sin(lat) ** 2)
    return float(np.degrees(lat)), float(np.degrees(np.arctan2(y_m, x_m))), float(height)


def dsn_site_geodetic(name: str) -> tuple[float, float, float]:
    """(latitude_deg, longitude_deg, altitude_m) of a named site."""
    if name in VLBA_SITES:
        return VLBA_SITES[name][1:]
    _, x, y, z = DSN_SITES_ECEF_M[name]
    return ecef_to_geodetic(x, y, z)
