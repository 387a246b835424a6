"""Per-run accuracy and consistency metrics from estimation errors and covariance diagonals."""

import numpy as np

from liaison_cli.dynamics.constants import SECONDS_PER_DAY


def error_norms(err, sigma, to_m, to_m_s):
    """Per-spacecraft 3-D error norms and 3-sigma bounds of the norm.

    err, sigma: (m, 6 n_sc) in LU, LU/TU. Returns dict of (m, n_sc) arrays in m and m/s.
    """
    m, n = err.shape
    e = err.reshape(m, n // 6, 6)
    s = sigma.reshape(m, n // 6, 6)
    return {
        "position_error_m": np.linalg.norm(e[:, :, 0:3], axis=2) * to_m,
        "velocity_error_m_s": np.linalg.norm(e[:, :, 3:6], axis=2) * to_m_s,
        "position_3sigma_m": 3.0 * np.sqrt(np.sum(s[:, :, 0:3] ** 2, axis=2)) * to_m,
        "velocity_3sigma_m_s": 3.0 * np.sqrt(np.sum(s[:, :, 3:6] ** 2, axis=2)) * to_m_s,
    }


def rms(values):
    """Root mean square of a 1-D sample; NaN for an empty one."""
    values = np.asarray(values)
    return float(np.sqrt(np.mean(np.square(values)))) if values.size else float("nan")


def fraction(mask):
    """Share of True in a boolean sample; NaN for an empty one."""
    mask = np.asarray(mask)
    return float(np.mean(mask)) if mask.size else float("nan")


def summary_rows(times_s, err, sigma, spacecraft, to_m, to_m_s, after_s=SECONDS_PER_DAY, data_end_step=-1):
    """One dict per spacecraft: RMS of the 3-D errors (all epochs after t0, and after `after_s`) and the
    fraction of (epoch, axis) samples whose error lies within 2 and 3 sigma of that axis. When the
    estimator's data end before the last epoch (a batch span), also the RMS over the epochs after it:
    002's DRMS of the prediction, sqrt(mean |e|^2)."""
    norms = error_norms(err, sigma, to_m, to_m_s)
    after_t0 = times_s > 0.0
    late = times_s >= after_s
    m, n = err.shape
    ratio = np.abs(err.reshape(m, n // 6, 6)) / sigma.reshape(m, n // 6, 6)
    rows = []
    for i, name in enumerate(spacecraft):
        r = ratio[:, i, :]
        rows.append(
            {
                "spacecraft": name,
                "rms_position_m": rms(norms["position_error_m"][after_t0, i]),
                "rms_velocity_m_s": rms(norms["velocity_error_m_s"][after_t0, i]),
                "rms_position_after_day1_m": rms(norms["position_error_m"][late, i]),
                "rms_velocity_after_day1_m_s": rms(norms["velocity_error_m_s"][late, i]),
                "frac_in_2sigma": fraction(r[after_t0] <= 2.0),
                "frac_in_3sigma": fraction(r[after_t0] <= 3.0),
                "frac_in_2sigma_after_day1": fraction(r[late] <= 2.0),
                "frac_in_3sigma_after_day1": fraction(r[late] <= 3.0),
            }
        )
        if 0 <= data_end_step < len(times_s) - 1:
            ahead = np.arange(len(times_s)) > data_end_step
            rows[-1]["rms_position_prediction_m"] = rms(norms["position_error_m"][ahead, i])
            rows[-1]["rms_velocity_prediction_m_s"] = rms(norms["velocity_error_m_s"][ahead, i])
    return rows, norms


def chi2_quantile(probability: float, dof: float) -> float:
    """The chi-square quantile, 2 * P^-1(dof / 2, p) with P the regularised lower incomplete gamma function
    (scipy.special: importing scipy.stats for chi2.ppf would cost about a second)."""
    from scipy.special import gammaincinv

    return 2.0 * float(gammaincinv(0.5 * dof, probability))


def nees_band(state_size: int, n_runs: int, confidence: float = 0.95):
    """Two-sided band for the run-averaged NEES: chi2(n_runs * state_size) / n_runs."""
    dof = n_runs * state_size
    lo = chi2_quantile((1.0 - confidence) / 2.0, dof) / n_runs
    hi = chi2_quantile(1.0 - (1.0 - confidence) / 2.0, dof) / n_runs
    return lo, hi


NEES_DIVERGENCE_PROBABILITY = 0.999


def nees_divergence_limit(state_size: int, factor: float) -> float:
    """The NEES a run must exceed throughout the window to count as diverged: `factor` times the 99.9 %
    chi-square quantile of the estimated state size."""
    return factor * chi2_quantile(NEES_DIVERGENCE_PROBABILITY, state_size)


def sustained_excess_step(nees, limit: float, window_steps: int) -> int:
    """The first epoch at which `nees` has been above `limit` for `window_steps` consecutive epochs (the
    epoch a navigator watching the filter would call it lost), or -1. Epoch 0 (the a-priori) is skipped."""
    above = np.asarray(nees)[1:] > limit
    if window_steps < 1 or above.size < window_steps:
        return -1
    run = 0
    for k, is_above in enumerate(above):
        run = run + 1 if is_above else 0
        if run == window_steps:
            return k + 1
    return -1
