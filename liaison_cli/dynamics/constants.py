"""Every physical constant of the package, in one place.

The Earth-Moon CRTBP is nondimensional: 1 LU is the Earth-Moon distance, 1 TU is chosen so that
the Moon's orbital period is 2*pi TU, and mu = m_moon / (m_earth + m_moon). The Turan et al. (2022)
Table 1 halo states close with these values (EML2: 3.3974 TU = 14.75 d; EML1: 2.752 TU = 11.95 d).
"""

import math

GM_EARTH_KM3_S2 = 398600.4354
GM_MOON_KM3_S2 = 4902.8001

MU = GM_MOON_KM3_S2 / (GM_EARTH_KM3_S2 + GM_MOON_KM3_S2)  # ~0.01215058
LU_KM = 384400.0
TU_S = math.sqrt(LU_KM**3 / (GM_EARTH_KM3_S2 + GM_MOON_KM3_S2))  # ~375190 s = 4.3425 d
VU_KM_S = LU_KM / TU_S  # ~1.0245 km/s
AU_KM_S2 = LU_KM / TU_S**2
M_PER_LU = LU_KM * 1e3
M_S_PER_VU = VU_KM_S * 1e3

SPEED_OF_LIGHT_M_S = 299792458.0  # exact (SI definition of the metre)
SPEED_OF_LIGHT_KM_S = SPEED_OF_LIGHT_M_S / 1e3
SPEED_OF_LIGHT_LU_TU = SPEED_OF_LIGHT_KM_S / VU_KM_S

SECONDS_PER_DAY = 86400.0
BOLTZMANN_DBW_PER_K_HZ = -228.5991672  # 10*log10(1.380649e-23)

MOON_POSITION_LU = (1.0 - MU, 0.0, 0.0)
EARTH_POSITION_LU = (-MU, 0.0, 0.0)

MOON_RADIUS_KM = 1737.4  # mean radius
EARTH_RADIUS_KM = 6371.0  # mean radius (occultation)
# WGS84 ellipsoid and the Earth's rotation rate relative to inertial space (IERS conventions value).
WGS84_EQUATORIAL_RADIUS_KM = 6378.137
WGS84_FLATTENING = 1.0 / 298.257223563
EARTH_ROTATION_RATE_RAD_S = 7.2921150e-5
