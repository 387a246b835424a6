"""Every physical constant of the package, in one place.

The Earth-Moon CRTBP is nondimensional: 1 LU is the Earth-Moon distance, 1 TU is chosen so that
the Moon's orbital period is 2*pi TU, and mu = m_moon / (m_earth + m_moon). The Turan et al. (2022)
Table 1 halo states close with these values (EML2: 3.3974 TU = 14.75 d; EML1: 2.752 TU = 11.95 d).
"""

import math

# The CRTBP's primaries: these two fix mu and TU, with which the Turan et al. (2022) Table 1 halo states
# close (below). The dated model keeps DE421's own values (DE421_GM_KM3_S2), 2.1e-9 apart for the Earth, so
# that its point masses are the ephemeris's; neither model mixes the two.
GM_EARTH_KM3_S2 = 398600.4354
GM_MOON_KM3_S2 = 4902.8001

MU = GM_MOON_KM3_S2 / (GM_EARTH_KM3_S2 + GM_MOON_KM3_S2)  # ~0.01215058
LU_KM = 384400.0
TU_S = math.sqrt(LU_KM**3 / (GM_EARTH_KM3_S2 + GM_MOON_KM3_S2))  # ~375190 s = 4.3425 d
VU_KM_S = LU_KM / TU_S  # ~1.0245 km/s
AU_KM_S2 = LU_KM / TU_S**2
M_PER_LU = LU_KM * 1e3
M_S_PER_VU = VU_KM_S * 1e3
M_S2_PER_AU = AU_KM_S2 * 1e3  # the acceleration unit LU/TU^2 in m/s^2

SPEED_OF_LIGHT_M_S = 299792458.0  # exact (SI definition of the metre)
SPEED_OF_LIGHT_KM_S = SPEED_OF_LIGHT_M_S / 1e3
SPEED_OF_LIGHT_LU_TU = SPEED_OF_LIGHT_KM_S / VU_KM_S

SECONDS_PER_DAY = 86400.0
J2000_JD = 2451545.0  # the J2000.0 epoch, 2000-01-01 12:00 TT, as a Julian date
MJD_OF_J2000 = 51544.5  # ... as a modified Julian date (the IERS tables' day count)
BOLTZMANN_DBW_PER_K_HZ = -228.5991672  # 10*log10(1.380649e-23)

MOON_POSITION_LU = (1.0 - MU, 0.0, 0.0)
EARTH_POSITION_LU = (-MU, 0.0, 0.0)

MOON_RADIUS_KM = 1737.4  # mean radius
EARTH_RADIUS_KM = 6371.0  # mean radius (occultation)
# WGS84 ellipsoid and the Earth's rotation rate relative to inertial space (IERS conventions value).
WGS84_EQUATORIAL_RADIUS_KM = 6378.137
WGS84_FLATTENING = 1.0 / 298.257223563
EARTH_ROTATION_RATE_RAD_S = 7.2921150e-5
# A geostationary orbit's altitude: radius 42,164.17 km above the WGS84 equator (sidereal-day orbit).
GEOSTATIONARY_ALTITUDE_M = 35786.03e3

# The dated model (003): DE421's GM values (km^3/s^2), Folkner, Williams & Boggs (2009), IPN PR 42-178,
# Table 8; planets as systems. Keys are dynamics.ephemeris's body codes (NAIF ids: 1-9 planet-system
# barycentres, 10 the Sun, 301 the Moon, 399 the Earth). The Earth's, 398600.436233, differs from the CRTBP's
# GM_EARTH_KM3_S2 above on purpose: each model keeps the value its own data were fitted with.
DE421_GM_KM3_S2 = {
    399: 398600.436233, 301: 4902.800076, 10: 132712440040.944,
    1: 22032.090000, 2: 324858.592000, 4: 42828.375214, 5: 126712764.800000, 6: 37940585.200000,
    7: 5794548.600000, 8: 6836535.000000, 9: 977.000000,
}
# Solar radiation pressure and the shadow cones of the dated model (Montenbruck & Gill 2000, §3.4).
AU_KM = 149597870.7  # IAU 2012, exact
SOLAR_FLUX_1AU_W_M2 = 1367.0  # gives P_1AU = 4.56e-6 N/m^2, the textbook value (Montenbruck & Gill 2000)
SUN_RADIUS_KM = 696000.0
# The Earth as the shadow's occulter: the IERS Conventions (2003) equatorial radius, not WGS84's 6378.137 km
# (0.4 m apart, nothing against a shadow cone's edge; kept so the dated runs stay as recorded), and not the
# mean EARTH_RADIUS_KM the CRTBP's occultation of links uses.
EARTH_SHADOW_RADIUS_KM = 6378.1366
# The IAU 1976 obliquity of the ecliptic at J2000: the ecliptic pole in ICRF axes (sets "prograde" transfers).
OBLIQUITY_J2000_DEG = 23.4392911
