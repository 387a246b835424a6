"""The Gauss-Newton parts both batch least-squares solvers share: the batch estimator (estimation.batch) and
the EKF's initial batch (estimation.initial_batch). Each solver keeps its own loop; these are its pieces:

  accumulate_row        one scalar measurement's weighted row h into Lambda += h' W h, N += h' W r
  add_apriori           Lambda + P0^-1 and N + P0^-1 (x_bar - x*): the a-priori information
  equilibrated_solve    Lambda dx = N by Cholesky after symmetric equilibration
  conditioned_solve     the same, refused above CONDITION_LIMIT (the batch estimator's solve)
  position_indices      the spacecraft position entries of the state, whose corrections judge convergence
  negligible_correction the convergence test on a position correction

The normal equations are solved by Cholesky after symmetric equilibration (D^-1/2 Lambda D^-1/2 with
D = diag(Lambda)): positions (LU) and velocities (LU/TU) differ by orders of magnitude in information,
and scaling removes that part of the conditioning. Cholesky loses about log10(cond) of 16 digits, so the batch
estimator records a solve with an equilibrated condition number above CONDITION_LIMIT as ill-conditioned (QR /
SRIF on the weighted design would then be the remedy; no scenario shipped comes near it).

Why the two loops stay two (each difference is in the numbers the golden runs record):
- the reference: the batch estimator integrates its own RK8 (a step count per interval) with one 6x6 Phi per
  spacecraft and may freeze the first iteration's Phi; the initial batch uses the EKF's propagator
  (filter_loop.time_update) with the full n x n Phi and accumulates the process noise for the hand-over;
- the step: the batch estimator takes every full step; the initial batch halves a step until its MAP cost
  falls (an a priori of 1,000 km is far outside Gauss-Newton's region of full steps);
- convergence: the batch estimator stops when no position correction exceeds the tolerance; the initial batch
  also when every one is below STEP_SIGMA_FRACTION of its own sigma, and re-solves at the solution for the
  covariance it hands over (the batch estimator reports the last solve's).
"""

import numpy as np
from numba import njit

from liaison_cli.estimation.blocks import BLOCK_SPACECRAFT

CONDITION_LIMIT = 1e12
STEP_SIGMA_FRACTION = 1e-3  # a correction below this share of its own sigma is negligible (initial batch)


@njit(cache=True)
def accumulate_row(lam, rhs, h, weight, r, nz):
    """Lambda (n, n) += h' weight h and N (n,) += h' weight r for one scalar measurement with row h (n,) and
    residual r, over the non-zero entries of h only; nz (n,) int64 is scratch."""
    m = 0
    for i in range(h.shape[0]):
        if h[i] != 0.0:
            nz[m] = i
            m += 1
    for p in range(m):
        i = nz[p]
        rhs[i] += h[i] * weight * r
        for q in range(m):
            lam[i, nz[q]] += h[i] * weight * h[nz[q]]


def add_apriori(lam, rhs, info_apriori, x, x_apriori):
    """The normal equations with the a-priori information P0^-1 about x_apriori, linearised at x."""
    return lam + info_apriori, rhs + info_apriori @ (x_apriori - x)


def equilibrated_solve(lam, rhs):
    """Lambda dx = N by Cholesky after symmetric scaling by D = diag(Lambda) (module docstring): (dx, Lambda^-1),
    or (None, None) when Lambda is not positive definite."""
    d = np.sqrt(np.diag(lam))
    if not np.all(np.isfinite(d)) or np.any(d <= 0.0):
        return None, None
    try:
        L = np.linalg.cholesky(lam / np.outer(d, d))
    except np.linalg.LinAlgError:
        return None, None
    dx = np.linalg.solve(L.T, np.linalg.solve(L, rhs / d)) / d
    L_inv = np.linalg.solve(L, np.eye(lam.shape[0]))
    return dx, (L_inv.T @ L_inv) / np.outer(d, d)


def conditioned_solve(lam, rhs):
    """equilibrated_solve refused above CONDITION_LIMIT; returns dx, Lambda^-1, cond (equilibrated), with
    (None, None, cond) when refused."""
    d = np.sqrt(np.diag(lam))
    if not np.all(np.isfinite(d)) or np.any(d <= 0.0):
        return None, None, np.inf
    eig = np.linalg.eigvalsh(lam / np.outer(d, d))
    cond = float(eig[-1] / eig[0]) if eig[0] > 0 else np.inf
    if not np.isfinite(cond) or cond > CONDITION_LIMIT:
        return None, None, cond
    dx, cov = equilibrated_solve(lam, rhs)
    return dx, cov, cond


def position_indices(block_kind, block_start) -> np.ndarray:
    """The state entries of every spacecraft's position (3 per spacecraft block, in block order)."""
    return np.concatenate([np.arange(a, a + 3) for a, kind in zip(block_start, block_kind)
                           if kind == BLOCK_SPACECRAFT])


def negligible_correction(step, tolerance_lu, sigma=None) -> bool:
    """Converged: no position correction `step` exceeds tolerance_lu, or (given the positions' 1-sigma `sigma`)
    every one is below STEP_SIGMA_FRACTION of its own sigma: with weak information (a short window) the cost is
    flat to round-off along the uncertain directions, and a further step there is noise, not progress."""
    if np.max(np.abs(step)) < tolerance_lu:
        return True
    return sigma is not None and bool(np.all(np.abs(step) < STEP_SIGMA_FRACTION * sigma))
