"""CRTBP (LU, TU, barycentric rotating) <-> geocentric ICRF (km, km/s) through the instantaneous Earth-Moon
rotating frame built from the DE421 Moon state (003: a CRTBP halo carried into the dated sky).

Frame at an epoch, from the Moon's geocentric state (r, v): x along r, z along r x v, y = z x x; its
length unit l = |r| (the instantaneous Earth-Moon distance), its rate omega = |r x v| / l^2, and l' = r.v / l.
A CRTBP state rho (barycentric, Earth at -mu) maps to the geocentric p = rho + (mu, 0, 0) and
  r = l R p,   v = R (l' p + l omega (rho' + z x p)),
rho' being the CRTBP velocity in LU per (1/omega). The inverse is exact (tested).
"""

import numpy as np


def rotating_axes(moon_state_km):
    """(R (3, 3) with columns x, y, z; l km; l' km/s; omega rad/s) from the Moon's geocentric state (6,)."""
    r, v = np.asarray(moon_state_km[:3], dtype=float), np.asarray(moon_state_km[3:6], dtype=float)
    l_km = float(np.linalg.norm(r))
    h = np.cross(r, v)
    x = r / l_km
    z = h / np.linalg.norm(h)
    y = np.cross(z, x)
    return np.column_stack([x, y, z]), l_km, float(r @ v) / l_km, float(np.linalg.norm(h)) / l_km**2


def crtbp_to_inertial(state_lu, moon_state_km, mu: float) -> np.ndarray:
    R, l_km, l_dot, omega = rotating_axes(moon_state_km)
    p = np.asarray(state_lu[:3], dtype=float) + np.array([mu, 0.0, 0.0])
    rho_dot = np.asarray(state_lu[3:6], dtype=float)
    r = l_km * (R @ p)
    v = R @ (l_dot * p + l_km * omega * (rho_dot + np.cross([0.0, 0.0, 1.0], p)))
    return np.concatenate([r, v])


def inertial_to_crtbp(state_km, moon_state_km, mu: float) -> np.ndarray:
    R, l_km, l_dot, omega = rotating_axes(moon_state_km)
    p = R.T @ np.asarray(state_km[:3], dtype=float) / l_km
    rho_dot = (R.T @ np.asarray(state_km[3:6], dtype=float) - l_dot * p) / (l_km * omega) - np.cross([0.0, 0.0, 1.0], p)
    return np.concatenate([p - np.array([mu, 0.0, 0.0]), rho_dot])
