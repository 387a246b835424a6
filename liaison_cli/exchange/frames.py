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


# --- a CRTBP result in ICRF axes (liaison export --frame icrf --epoch ...) -----------------------------------------
#
# The CRTBP's own inertial frame: the Earth and the Moon on circular orbits about their barycentre at the mean
# motion n = 1 / TU_S, in a fixed plane. Anchored at a user-given epoch t0, its axes are taken from the real
# Moon's geocentric state there (DE421): x towards the Moon, z along its orbit normal. At t0 + t the rotating
# axes have turned by n t about z, so a CRTBP state rho (LU, VU, barycentric) is, geocentric,
#   r = LU R(t) p,   v = VU R(t) (rho' + z x p),   p = rho + (mu, 0, 0),   R(t) = R0 Rz(n t),
# a rigid motion of the CRTBP's frame: every distance and range rate the filter saw is kept exactly, so an
# exported TDM agrees with the exported OEMs. What it leaves out is the real Moon's departure from the circular
# one: its distance differs by up to about 22,000 km and, its rate varying by +-11 % about the mean motion, its
# longitude by up to about 12 degrees within a month (measured from 60 daily anchors in 2030: 21,421 km, 11.4
# degrees; 10.5 degrees within 10 days), so the exported states sit near, not on, the real sky's libration points
# (docs/exchange.md; tests/cli/test_crtbp_oem_import.py).


def crtbp_anchor_axes(moon_state_km) -> np.ndarray:
    """R0 (3, 3), columns x, y, z: the CRTBP's axes at the anchor epoch from the Moon's geocentric ICRF state."""
    r, v = np.asarray(moon_state_km[:3], dtype=float), np.asarray(moon_state_km[3:6], dtype=float)
    x = r / np.linalg.norm(r)
    z = np.cross(r, v)
    z /= np.linalg.norm(z)
    return np.column_stack([x, np.cross(z, x), z])


def crtbp_icrf_jacobians(axes0: np.ndarray, times_s: np.ndarray) -> np.ndarray:
    """(m, 6, 6): d(geocentric ICRF state, km, km/s) / d(CRTBP state, LU, VU) at t0 + times_s; the map is affine
    (crtbp_to_icrf), so it carries a covariance exactly: P_icrf = J P J^T."""
    from liaison_cli.dynamics.constants import TU_S

    angle = np.asarray(times_s, dtype=float) / TU_S
    cos, sin = np.cos(angle), np.sin(angle)
    turn = np.zeros((len(angle), 3, 3))
    turn[:, 0, 0], turn[:, 0, 1], turn[:, 1, 0], turn[:, 1, 1], turn[:, 2, 2] = cos, -sin, sin, cos, 1.0
    rotation = np.einsum("ij,kjl->kil", axes0, turn)
    z_cross = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    out = np.zeros((len(angle), 6, 6))
    out[:, :3, :3] = LU_KM * rotation
    out[:, 3:, :3] = VU_KM_S * rotation @ z_cross
    out[:, 3:, 3:] = VU_KM_S * rotation
    return out


def crtbp_to_icrf(states_scaled: np.ndarray, times_s: np.ndarray, axes0: np.ndarray, mu: float,
                  centre: str = "EARTH") -> np.ndarray:
    """(m, 6) CRTBP states (LU, VU) at t0 + times_s as ICRF states (km, km/s) about the Earth or, with
    centre "MOON", about the CRTBP's Moon (at 1 - mu on the rotating x axis: the circular Moon, see above)."""
    offset = np.array([mu if centre == "EARTH" else mu - 1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    jacobians = crtbp_icrf_jacobians(axes0, times_s)
    return np.einsum("kij,kj->ki", jacobians, np.asarray(states_scaled, dtype=float) + offset)
