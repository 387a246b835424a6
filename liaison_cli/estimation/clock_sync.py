"""Clock synchronisation by a quadratic fit (002 §4): delta_t(t) = a0 + a1 (t - t0) + a2 (t - t0)^2 fitted
by weighted least squares to the clock offsets a dual one-way link measures over a sync window, relative
to the main spacecraft's clock; then evaluated over the window and predicted past it.

Pure numerics: times in s, offsets in s, sigma in s.
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ClockFit:
    """coefficients (degree + 1,) [a0 (s), a1 (s/s), a2 (1/s)] about t_ref_s; covariance of them; the
    epochs used; the post-fit residual RMS (s)."""

    t_ref_s: float
    coefficients: np.ndarray
    covariance: np.ndarray
    n_used: int
    residual_rms_s: float

    def offset_s(self, t_s) -> np.ndarray:
        dt = np.asarray(t_s, dtype=float) - self.t_ref_s
        return np.polynomial.polynomial.polyval(dt, self.coefficients)


def fit_clock_polynomial(t_s, offsets_s, sigma_s: float, t_ref_s: float, degree: int = 2) -> ClockFit:
    """Weighted least squares of a polynomial in (t - t_ref) to the finite offsets (NaN = no measurement).

    Solved by QR of the weighted design matrix (its columns span seconds^0..^2 over hours: QR avoids the
    squared condition number of the normal equations). Raises ValueError with fewer epochs than unknowns.
    """
    t_s = np.asarray(t_s, dtype=float)
    offsets_s = np.asarray(offsets_s, dtype=float)
    use = np.isfinite(offsets_s)
    if use.sum() < degree + 1:
        raise ValueError(f"clock fit needs at least {degree + 1} offsets, got {int(use.sum())}")
    dt = t_s[use] - t_ref_s
    scale = max(float(np.max(np.abs(dt))), 1.0)  # columns in (dt / scale)^k keep the design well scaled
    A = np.vander(dt / scale, degree + 1, increasing=True) / sigma_s  # A x = y / sigma, W = 1 / sigma^2
    q, r = np.linalg.qr(A)
    b = offsets_s[use] / sigma_s
    x_scaled = np.linalg.solve(r, q.T @ b)
    r_inv = np.linalg.solve(r, np.eye(degree + 1))
    cov_scaled = r_inv @ r_inv.T
    unscale = scale ** -np.arange(degree + 1)
    coefficients = x_scaled * unscale
    covariance = cov_scaled * np.outer(unscale, unscale)
    residual = offsets_s[use] - np.polynomial.polynomial.polyval(dt, coefficients)
    return ClockFit(t_ref_s, coefficients, covariance, int(use.sum()), float(np.sqrt(np.mean(residual**2))))


def sync_errors(times_s, measured_offsets_s, true_offsets_s, sigma_s: float, window_end_s: float,
                window_s: float, prediction_s: float, degree: int = 2) -> dict:
    """Fit over (window_end - window, window_end] and compare with the true offsets: RMS (s) over the window's
    epochs and over the prediction epochs (window_end, window_end + prediction]."""
    times_s = np.asarray(times_s, dtype=float)
    in_window = (times_s > window_end_s - window_s - 1e-9) & (times_s <= window_end_s + 1e-9)
    ahead = (times_s > window_end_s + 1e-9) & (times_s <= window_end_s + prediction_s + 1e-9)
    fit = fit_clock_polynomial(times_s[in_window], np.asarray(measured_offsets_s)[in_window], sigma_s,
                               window_end_s, degree)
    error = fit.offset_s(times_s) - np.asarray(true_offsets_s, dtype=float)

    def rms(mask):
        return float(np.sqrt(np.mean(error[mask] ** 2))) if mask.any() else float("nan")

    return {"rms_window_s": rms(in_window), "rms_prediction_s": rms(ahead), "fit": fit}
