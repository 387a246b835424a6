"""Moon-centred Keplerian elements -> CRTBP rotating-frame state.

The elements are expressed in Moon-centred inertial axes that coincide with the rotating frame at
the scenario epoch, so the rotating-frame velocity is v_rot = v_inertial - omega x r with omega = z_hat
(1 rad/TU). The Keplerian state is only the initial condition: the orbiter is then propagated in the
full CRTBP like every other spacecraft.
"""

import math

import numpy as np

from liaison_cli.dynamics.constants import GM_MOON_KM3_S2, LU_KM, MU, VU_KM_S


def elements_to_moon_inertial(a_km, e, i_deg, raan_deg, argp_deg, ta_deg, gm_km3_s2=GM_MOON_KM3_S2):
    """Classical elements -> (position_km (3,), velocity_km_s (3,)) in the central body's inertial axes."""
    i, raan, argp, ta = (math.radians(v) for v in (i_deg, raan_deg, argp_deg, ta_deg))
    p_km = a_km * (1.0 - e * e)
    r_km = p_km / (1.0 + e * math.cos(ta))
    r_pf = np.array([r_km * math.cos(ta), r_km * math.sin(ta), 0.0])
    v_pf = math.sqrt(gm_km3_s2 / p_km) * np.array([-math.sin(ta), e + math.cos(ta), 0.0])
    cO, sO, ci, si, cw, sw = (
        math.cos(raan),
        math.sin(raan),
        math.cos(i),
        math.sin(i),
        math.cos(argp),
        math.sin(argp),
    )
    # Perifocal -> inertial rotation R3(-raan) R1(-i) R3(-argp).
    rot = np.array(
        [
            [cO * cw - sO * sw * ci, -cO * sw - sO * cw * ci, sO * si],
            [sO * cw + cO * sw * ci, -sO * sw + cO * cw * ci, -cO * si],
            [sw * si, cw * si, ci],
        ]
    )
    return rot @ r_pf, rot @ v_pf


def lunar_orbiter_state_lu(a_km, e, i_deg, raan_deg, argp_deg, ta_deg, mu=MU):
    """Moon-centred elements -> barycentric rotating-frame state (6,) in LU, LU/TU."""
    r_km, v_km_s = elements_to_moon_inertial(a_km, e, i_deg, raan_deg, argp_deg, ta_deg)
    r_lu = r_km / LU_KM
    v_lu = v_km_s / VU_KM_S
    # Moon is at rest in the rotating frame; subtract the frame rotation (omega = z_hat, 1 rad/TU).
    v_rot = v_lu - np.array([-r_lu[1], r_lu[0], 0.0])
    return np.concatenate([r_lu + np.array([1.0 - mu, 0.0, 0.0]), v_rot])


def keplerian_period_s(a_km, gm_km3_s2=GM_MOON_KM3_S2):
    return 2.0 * math.pi * math.sqrt(a_km**3 / gm_km3_s2)
