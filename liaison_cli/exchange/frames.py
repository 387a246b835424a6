"""Reference frames of CCSDS files: geocentric ICRF (also named GCRF) as liaison's dated frame, EME2000 (the mean
equator and equinox of J2000) by the IAU 2000 frame bias, and the CRTBP's Earth-Moon rotating frame by name."""

from functools import lru_cache

import numpy as np

from liaison_cli.dynamics.constants import LU_KM, VU_KM_S

ICRF_NAMES = ("ICRF", "GCRF")
EME2000 = "EME2000"
DATED_FRAMES = (*ICRF_NAMES, EME2000)
EARTH_CENTRES = ("EARTH",)
# The CRTBP's frame: origin the Earth-Moon barycentre, x from the Earth to the Moon, z along the orbit normal,
# units km and km/s (one LU = 384,400 km); not a SANA frame, so the files say so in COMMENT lines.
CRTBP_FRAME = "EARTH_MOON_ROTATING"
CRTBP_CENTRE = "EARTH-MOON BARYCENTER"
CRTBP_KM_PER_SCALED = np.array([LU_KM] * 3 + [VU_KM_S] * 3)  # a scaled CRTBP state (LU, VU) -> km, km/s


@lru_cache(maxsize=1)
def frame_bias() -> np.ndarray:
    """B (3, 3): EME2000 vector = B @ ICRF vector (IAU 2000 frame bias, erfa.bp00's rb; about 23 mas)."""
    import erfa

    rb, _, _ = erfa.bp00(2451545.0, 0.0)
    return np.asarray(rb)


def to_icrf(states_km: np.ndarray, frame: str) -> np.ndarray:
    """(m, 6) states of `frame` (a DATED_FRAMES name) as geocentric ICRF states."""
    if frame in ICRF_NAMES:
        return np.asarray(states_km, dtype=float)
    rotation = frame_bias().T
    return np.hstack([states_km[:, :3] @ rotation.T, states_km[:, 3:] @ rotation.T])
