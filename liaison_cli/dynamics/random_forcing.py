"""Random forces the truth feels and the filter does not model: sample paths of a first-order Gauss-Markov
acceleration (scenario model_error.truth_acceleration_sigma_m_s2), drawn per run."""

import numpy as np
from numba import njit


def gauss_markov_samples(rng: np.random.Generator, n_processes: int, n_epochs: int, step_s: float,
                         sigma: float, tau_s: float) -> np.ndarray:
    """(n_processes, n_epochs, 3) samples at epochs step_s apart of independent stationary first-order
    Gauss-Markov processes, one per process and axis, of 1-sigma `sigma` (its units) and correlation time tau_s.

    Exact discretisation (Maybeck, Stochastic Models vol. 1, Eq. 4-111 with a scalar first-order shaping
    filter): a_0 ~ N(0, sigma^2), a_{k+1} = phi a_k + sigma sqrt(1 - phi^2) w_k with phi = exp(-step_s / tau_s)
    and w_k ~ N(0, 1), so every sample has variance sigma^2 and lag-k correlation phi^k. The draws are taken
    process by process, epoch by epoch: one process's path does not depend on how many others there are."""
    phi = float(np.exp(-step_s / tau_s))
    drive = sigma * np.sqrt(1.0 - phi * phi)
    w = rng.standard_normal((n_processes, n_epochs, 3))  # C order: process by process, epoch by epoch
    return _first_order_recursion(w, sigma, phi, drive)


@njit(cache=True)
def _first_order_recursion(w, sigma, phi, drive):
    """out[p, 0] = sigma w[p, 0]; out[p, k] = phi out[p, k - 1] + drive w[p, k] (compiled: a Python loop over
    the epochs cost 18 ms of a 10-day run)."""
    out = np.empty_like(w)
    for p in range(w.shape[0]):
        for i in range(3):
            out[p, 0, i] = sigma * w[p, 0, i]
        for k in range(1, w.shape[1]):
            for i in range(3):
                out[p, k, i] = phi * out[p, k - 1, i] + drive * w[p, k, i]
    return out
