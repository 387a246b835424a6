"""Two-state clock model: phase x1 (s) and frequency x2 (s/s), optionally aging x3 (1/s).

Continuous model: dx1 = x2 dt + sigma1 dW1, dx2 = x3 dt + sigma2 dW2, dx3 = sigma3 dW3, with diffusion
coefficients sigma1 (s/sqrt(s), white frequency noise), sigma2 (1/sqrt(s), random-walk frequency noise)
and sigma3 (1/s^1.5, aging noise). Over dt the transition is Phi_ij = dt^(j-i) / (j-i)! and the process
noise is the classic integrated covariance (e.g. Zucca & Tavella 2005). Allan deviation relation:
sigma_y(tau)^2 = sigma1^2 / tau + sigma2^2 tau / 3 (+ sigma3^2 tau^3 / 20).
"""

import math

import numpy as np


def clock_transition(dt_s: float, size: int = 2) -> np.ndarray:
    """(size, size) Phi(dt) of the clock states."""
    phi = np.eye(size)
    for i in range(size):
        for j in range(i + 1, size):
            phi[i, j] = dt_s ** (j - i) / math.factorial(j - i)
    return phi


def clock_process_noise(dt_s: float, sigma1: float, sigma2: float, sigma3: float = 0.0, size: int = 2) -> np.ndarray:
    """(size, size) Q(dt) in s^2, s^2/s, ... for the diffusions above."""
    q = np.array([
        [sigma1**2 * dt_s + sigma2**2 * dt_s**3 / 3.0 + sigma3**2 * dt_s**5 / 20.0,
         sigma2**2 * dt_s**2 / 2.0 + sigma3**2 * dt_s**4 / 8.0, sigma3**2 * dt_s**3 / 6.0],
        [sigma2**2 * dt_s**2 / 2.0 + sigma3**2 * dt_s**4 / 8.0, sigma2**2 * dt_s + sigma3**2 * dt_s**3 / 3.0,
         sigma3**2 * dt_s**2 / 2.0],
        [sigma3**2 * dt_s**3 / 6.0, sigma3**2 * dt_s**2 / 2.0, sigma3**2 * dt_s],
    ])
    return q[:size, :size]


def simulate_clock(rng, n_steps: int, dt_s: float, x0, sigma1: float, sigma2: float, sigma3: float = 0.0,
                   mu1: float = 0.0, mu2: float = 0.0):
    """A truth clock history (n_steps, size) from x0 (size,) by the exact discrete model.

    mu1 (s/s) and mu2 (1/s) are the deterministic drift terms of 002 Eq. 13-14 (Galleani et al. 2003):
    x1 += (x2 + mu1) dt + mu2 dt^2 / 2 and x2 += mu2 dt, on top of the random steps J_k (Eq. 15-16). The
    random draws do not depend on mu1 / mu2, so the same seed gives the same noise with or without drift.
    """
    x0 = np.asarray(x0, dtype=float)
    size = x0.shape[0]
    phi = clock_transition(dt_s, size)
    chol = np.linalg.cholesky(clock_process_noise(dt_s, sigma1, sigma2, sigma3, size) + 1e-300 * np.eye(size))
    drift = np.zeros(size)
    drift[0] = mu1 * dt_s + mu2 * dt_s**2 / 2.0
    if size > 1:
        drift[1] = mu2 * dt_s
    out = np.empty((n_steps, size))
    out[0] = x0
    steps = rng.standard_normal((n_steps - 1, size))
    for k in range(1, n_steps):
        out[k] = phi @ out[k - 1] + drift + chol @ steps[k - 1]
    return out


def allan_deviation_model(tau_s, sigma1: float, sigma2: float):
    """sigma_y(tau) of the two-state model: sqrt(sigma1^2 / tau + sigma2^2 tau / 3)."""
    tau_s = np.asarray(tau_s, dtype=float)
    return np.sqrt(sigma1**2 / tau_s + sigma2**2 * tau_s / 3.0)
