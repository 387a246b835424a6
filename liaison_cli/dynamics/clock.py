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


def simulate_clock(rng, n_steps: int, dt_s: float, x0, sigma1: float, sigma2: float, sigma3: float = 0.0):
    """A truth clock history (n_steps, size) from x0 (size,) by the exact discrete model."""
    x0 = np.asarray(x0, dtype=float)
    size = x0.shape[0]
    phi = clock_transition(dt_s, size)
    chol = np.linalg.cholesky(clock_process_noise(dt_s, sigma1, sigma2, sigma3, size) + 1e-300 * np.eye(size))
    out = np.empty((n_steps, size))
    out[0] = x0
    steps = rng.standard_normal((n_steps - 1, size))
    for k in range(1, n_steps):
        out[k] = phi @ out[k - 1] + chol @ steps[k - 1]
    return out
