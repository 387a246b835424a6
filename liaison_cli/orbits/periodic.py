"""Symmetric periodic orbits of the Earth-Moon CRTBP: differential correction and pseudo-arclength continuation.

Orbits symmetric about the x-z plane cross it perpendicularly twice per period. Start on the plane,
state0 = [x0, 0, z0, 0, vy0, 0], integrate half a period T/2 and ask for another perpendicular crossing:

    F(X) = [y, vx, vz](T/2) = 0,   X = [x0, z0, vy0, T/2]   (spatial: halo, NRHO)
    F(X) = [y, vx](T/2)     = 0,   X = [x0, vy0, T/2]       (planar: Lyapunov, DRO)

DF comes from the STM at T/2 and the state derivative there. One unknown more than equations leaves a
one-parameter family: `correct` fixes one variable (or takes the minimum-norm Newton step), `continue_family`
walks along the family with pseudo-arclength steps (the tangent is the null vector of DF). Everything is
in LU / TU; a `PeriodicOrbit` also carries its period, Jacobi constant, stability index and closure error.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import LU_KM, MOON_RADIUS_KM, MU
from liaison_cli.dynamics.crtbp import derivative, jacobi_constant
from liaison_cli.dynamics.integrators.dop853 import dop853_state_stm

RTOL = 1e-13
ATOL = 1e-14

_SPATIAL_FREE = (0, 2, 4)  # x0, z0, vy0
_SPATIAL_CONSTRAINED = (1, 3, 5)  # y, vx, vz at T/2
_PLANAR_FREE = (0, 4)
_PLANAR_CONSTRAINED = (1, 3)


class CorrectionError(RuntimeError):
    """Newton iterations did not converge."""


def state_from(X, planar: bool) -> np.ndarray:
    if planar:
        return np.array([X[0], 0.0, 0.0, 0.0, X[1], 0.0])
    return np.array([X[0], 0.0, X[1], 0.0, X[2], 0.0])


def residual_and_jacobian(X, planar: bool, mu: float = MU):
    """F (k,) and DF (k, k+1) for free variables X (k+1,), k = 2 planar / 3 spatial."""
    free, constrained = (_PLANAR_FREE, _PLANAR_CONSTRAINED) if planar else (_SPATIAL_FREE, _SPATIAL_CONSTRAINED)
    half_period = X[-1]
    states, stms = dop853_state_stm(state_from(X, planar), np.array([0.0, half_period]), mu, RTOL, ATOL)
    end, phi = states[-1], stms[-1]
    rate = derivative(end, mu)
    F = end[list(constrained)]
    DF = np.empty((len(constrained), len(free) + 1))
    DF[:, :-1] = phi[np.ix_(constrained, free)]
    DF[:, -1] = rate[list(constrained)]
    return F, DF


def correct(X, planar: bool, fixed: int | None = None, tol: float = 1e-12, max_iter: int = 30, mu: float = MU):
    """Newton from a guess X to a periodic orbit. `fixed`: index of X held constant (e.g. -1 = half period);
    None takes minimum-norm steps. Returns (X, iterations); raises CorrectionError."""
    X = np.array(X, dtype=float)
    for iteration in range(max_iter):
        F, DF = residual_and_jacobian(X, planar, mu)
        if not np.all(np.isfinite(F)):
            raise CorrectionError("non-finite residual")
        if np.max(np.abs(F)) < tol:
            return X, iteration
        if fixed is None:
            dX = -np.linalg.lstsq(DF, F, rcond=None)[0]
        else:
            keep = [i for i in range(len(X)) if i != fixed % len(X)]
            dX = np.zeros_like(X)
            dX[keep] = -np.linalg.solve(DF[:, keep], F)
        X = X + dX
        if X[-1] <= 0.0:
            raise CorrectionError("half period became negative")
    raise CorrectionError(f"no convergence in {max_iter} iterations (|F| = {np.max(np.abs(F)):.2e})")


def _null_vector(DF, previous=None):
    tangent = np.linalg.svd(DF)[2][-1]
    if previous is not None and tangent @ previous < 0.0:
        tangent = -tangent
    return tangent


def continue_family(X0, planar: bool, steps: int, step: float, direction: float = 1.0,
                    keep_going=lambda X: True, max_step: float | None = None, mu: float = MU) -> list:
    """Pseudo-arclength continuation from a corrected X0. Returns the corrected X of up to `steps` new
    members, stopping early when `keep_going(X)` is False or the step size collapses."""
    max_step = max_step or 4.0 * step
    _, DF = residual_and_jacobian(X0, planar, mu)
    tangent = _null_vector(DF)
    if tangent[0] * direction < 0.0:
        tangent = -tangent
    members, X_prev = [], np.array(X0, dtype=float)
    while len(members) < steps and step > 1e-7:
        X = X_prev + step * tangent
        try:
            for iteration in range(12):
                F, DF = residual_and_jacobian(X, planar, mu)
                G = np.append(F, tangent @ (X - X_prev) - step)
                if np.max(np.abs(F)) < 1e-12 and abs(G[-1]) < 1e-10:
                    break
                J = np.vstack([DF, tangent])
                X = X - np.linalg.solve(J, G)
            else:
                raise CorrectionError("continuation step did not converge")
        except (CorrectionError, np.linalg.LinAlgError, RuntimeError, ValueError):
            step *= 0.5
            continue
        if not keep_going(X):
            break
        members.append(X)
        tangent = _null_vector(DF, tangent)
        X_prev = X
        if iteration <= 3:
            step = min(step * 1.5, max_step)
    return members


@dataclass(frozen=True)
class PeriodicOrbit:
    """One corrected member: initial state on the x-z plane (LU, LU/TU) and its properties."""

    state: tuple
    period_tu: float
    jacobi: float
    stability_index: float
    closure_lu: float
    x_amplitude_lu: float
    y_amplitude_lu: float
    z_amplitude_lu: float
    perilune_km: float
    apolune_km: float


def describe(X, planar: bool, mu: float = MU, samples: int = 400) -> PeriodicOrbit:
    """Propagate one full period (state + STM): closure, monodromy stability index, amplitudes, apsides."""
    state0 = state_from(X, planar)
    period = 2.0 * X[-1]
    times = np.linspace(0.0, period, samples + 1)
    states, stms = dop853_state_stm(state0, times, mu, RTOL, ATOL)
    eigenvalues = np.abs(np.linalg.eigvals(stms[-1]))
    lam = float(np.max(eigenvalues))
    moon_km = np.linalg.norm(states[:, :3] - np.array([1.0 - mu, 0.0, 0.0]), axis=1) * LU_KM
    return PeriodicOrbit(
        state=tuple(float(v) for v in state0),
        period_tu=float(period),
        jacobi=float(jacobi_constant(state0, mu)),
        stability_index=0.5 * (lam + 1.0 / lam),
        closure_lu=float(np.max(np.abs(states[-1] - state0))),
        x_amplitude_lu=float(np.ptp(states[:, 0]) / 2.0),
        y_amplitude_lu=float(np.ptp(states[:, 1]) / 2.0),
        z_amplitude_lu=float(np.max(np.abs(states[:, 2]))),
        perilune_km=float(moon_km.min()),
        apolune_km=float(moon_km.max()),
    )


def lagrange_point_x(point: int, mu: float = MU) -> float:
    """x of the collinear point L1 / L2 (Newton on the quintic's equilibrium condition)."""
    moon = 1.0 - mu
    x = moon - (mu / 3.0) ** (1.0 / 3.0) if point == 1 else moon + (mu / 3.0) ** (1.0 / 3.0)
    for _ in range(50):
        r1, r2 = abs(x + mu), abs(x - moon)
        f = x - (1.0 - mu) * (x + mu) / r1**3 - mu * (x - moon) / r2**3
        df = 1.0 + 2.0 * (1.0 - mu) / r1**3 + 2.0 * mu / r2**3
        x -= f / df
    return x


def lyapunov_guess(point: int, amplitude_lu: float, mu: float = MU) -> np.ndarray:
    """Planar X = [x0, vy0, T/2] from the linearised in-plane oscillation about L1 / L2."""
    xl = lagrange_point_x(point, mu)
    c2 = (1.0 - mu) / abs(xl + mu) ** 3 + mu / abs(xl - 1.0 + mu) ** 3
    omega = np.sqrt(0.5 * (2.0 - c2 + np.sqrt(9.0 * c2**2 - 8.0 * c2)))
    k = (omega**2 + 1.0 + 2.0 * c2) / (2.0 * omega)
    # x = xl - A cos(wt), y = k A sin(wt): starts on the x axis moving along +y.
    return np.array([xl - amplitude_lu, k * amplitude_lu * omega, np.pi / omega])
