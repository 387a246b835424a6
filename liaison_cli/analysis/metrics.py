"""Per-run accuracy and consistency metrics from estimation errors and covariance diagonals."""

import math
from functools import lru_cache
from statistics import NormalDist

import numpy as np

from liaison_cli.dynamics.constants import SECONDS_PER_DAY


def error_norms(err, sigma, to_m, to_m_s):
    """Per-spacecraft 3-D error norms and 3-sigma bounds of the norm.

    err, sigma: (m, 6 n_sc) in LU, LU/TU. Returns dict of (m, n_sc) arrays in m and m/s.
    """
    m, n = err.shape
    # The squares summed over each 3-vector at once (position, velocity), in the order np.linalg.norm sums them:
    # the same numbers as four norms of strided slices, at a quarter of the cost (a run records this).
    e2, s2 = (_sum_of_three(np.square(values).reshape(m, n // 6, 2, 3)) for values in (err, sigma))
    return {
        "position_error_m": np.sqrt(e2[:, :, 0]) * to_m,
        "velocity_error_m_s": np.sqrt(e2[:, :, 1]) * to_m_s,
        "position_3sigma_m": 3.0 * np.sqrt(s2[:, :, 0]) * to_m,
        "velocity_3sigma_m_s": 3.0 * np.sqrt(s2[:, :, 1]) * to_m_s,
    }


def _sum_of_three(squares):
    """(..., 3) -> (...): (a0 + a1) + a2, the order a reduction over three elements adds in."""
    return squares[..., 0] + squares[..., 1] + squares[..., 2]


def rms(values):
    """Root mean square of a 1-D sample; NaN for an empty one."""
    values = np.asarray(values)
    return float(np.sqrt(np.mean(np.square(values)))) if values.size else float("nan")


def fraction(mask):
    """Share of True in a boolean sample; NaN for an empty one."""
    mask = np.asarray(mask)
    return float(np.mean(mask)) if mask.size else float("nan")


# A run whose error RMS after the settle time exceeds this many times its filter's sigma RMS, or falls
# below its inverse, fails the ratio test (analysis.consistency). For a consistent filter the ratio is 1 up to sampling: the errors of one run are strongly
# correlated in time (a few independent samples per orbit), so single runs spread by tens of per cent and
# a 10-run campaign by ~10-20 %; 1.5 is far outside that and still flags a filter whose sigma a navigator
# would not trust (a 3-sigma bound that is really 2-sigma).
CONSISTENCY_RATIO_LIMIT = 1.5
NEES_BAND_PROBABILITY = 0.95


def error_and_sigma(norms, epochs, spacecraft_index: int, label: str) -> dict:
    """Over the selected epochs (boolean mask) of one spacecraft: the RMS of the 3-D error norm, the RMS of the
    sigma of that norm (3-sigma bound / 3) and their ratio, for position and velocity, as
    rms_{kind}_{label}_{unit}, sigma_{kind}_{label}_{unit} and {kind}_error_to_sigma_{label}."""
    return _error_and_sigma(_Columns(norms), _Epochs(epochs), spacecraft_index, label)


def _error_and_sigma(columns, epochs, i: int, label: str) -> dict:
    out = {}
    for kind, unit in (("position", "m"), ("velocity", "m_s")):
        error = rms(epochs.of(columns.row(f"{kind}_error_{unit}", i)))
        spread = rms(epochs.of(columns.row(f"{kind}_3sigma_{unit}", i)) / 3.0)
        out[f"rms_{kind}_{label}_{unit}"] = error
        out[f"sigma_{kind}_{label}_{unit}"] = spread
        out[f"{kind}_error_to_sigma_{label}"] = error / spread if spread > 0 else float("nan")
    return out


class _Columns:
    """A norms dict's (m, n_sc) arrays as contiguous per-spacecraft rows, made on first use: a run's summary
    reads each many times, and a contiguous row's epochs are a view, where a column's were a copy."""

    def __init__(self, norms):
        self.norms, self.rows = norms, {}

    def row(self, key: str, i: int):
        if key not in self.rows:
            self.rows[key] = np.ascontiguousarray(self.norms[key].T)
        return self.rows[key][i]


class _Epochs:
    """A boolean mask over the epochs, taken as a slice when it selects a run of epochs to the end (times
    increase: after t0, after the settle time, after the data), so that selecting is a view; the values are the
    same, in the same order, so every statistic of them is the same number."""

    def __init__(self, mask):
        self.mask = np.asarray(mask, dtype=bool)
        first = int(np.argmax(self.mask)) if self.mask.any() else self.mask.size
        suffix = bool(self.mask[first:].all()) and not self.mask[:first].any()
        self.start = first if suffix else None

    def of(self, row):
        return row[self.start:] if self.start is not None else row[self.mask]


def _nees_columns(nees, n_nees: int, settled) -> dict:
    """Over the settled epochs: the share of epochs whose whole-state NEES lies in its two-sided 95 % chi-square
    band of n_nees degrees of freedom, above it (the filter optimistic there; below it, pessimistic), and its
    mean. The verdict is analysis.consistency's."""
    low, high = nees_run_band(n_nees)
    out = {}
    if nees is not None and n_nees > 0:
        values = settled.of(np.asarray(nees))
        values = values[np.isfinite(values)]
        out["frac_nees_in_band_settled"] = fraction((values >= low) & (values <= high))
        out["frac_nees_above_band_settled"] = fraction(values > high)  # optimistic epochs (the rest: pessimistic)
        out["mean_nees_settled"] = float(np.mean(values)) if values.size else float("nan")
    else:
        out["frac_nees_in_band_settled"] = out["frac_nees_above_band_settled"] = float("nan")
        out["mean_nees_settled"] = float("nan")
    return out


def campaign_error_to_sigma(error_rms, sigma_rms) -> float:
    """A campaign's ratio from its runs' settled error RMS and sigma RMS: sqrt(mean e^2 / mean s^2), the RMS
    over every run's settled epochs of the error divided by that of the sigma (NaN without runs)."""
    error_rms, sigma_rms = np.asarray(error_rms, dtype=float), np.asarray(sigma_rms, dtype=float)
    if error_rms.size == 0 or sigma_rms.size == 0:
        return float("nan")
    return float(np.sqrt(np.mean(error_rms**2) / np.mean(sigma_rms**2)))


def nees_run_band(n_nees: int, probability: float = NEES_BAND_PROBABILITY) -> tuple[float, float]:
    """The two-sided band a single run's NEES of n_nees states lies in with `probability` (chi-square)."""
    if n_nees <= 0:
        return float("nan"), float("nan")
    tail = (1.0 - probability) / 2.0
    return chi2_quantile(tail, n_nees), chi2_quantile(1.0 - tail, n_nees)


def summary_rows(times_s, err, sigma, spacecraft, to_m, to_m_s, after_s=SECONDS_PER_DAY, data_end_step=-1,
                 settle_s=SECONDS_PER_DAY, nees=None, n_nees: int = 0):
    """One dict per spacecraft: RMS of the 3-D errors (all epochs after t0, and after `after_s`) and the
    fraction of (epoch, axis) samples whose error lies within 2 and 3 sigma of that axis; the consistency
    columns after `settle_s` (the error and sigma RMS and their ratio, _error_and_sigma; the NEES shares,
    _nees_columns). When the estimator's data end before the last epoch (a
    batch span), also the RMS over the epochs after it: 002's DRMS of the prediction, sqrt(mean |e|^2)."""
    norms = error_norms(err, sigma, to_m, to_m_s)
    columns = _Columns(norms)
    after_t0, late, settled = (_Epochs(times_s > 0.0), _Epochs(times_s >= after_s), _Epochs(times_s >= settle_s))
    m, n = err.shape
    ratio = np.abs(err.reshape(m, n // 6, 6)) / sigma.reshape(m, n // 6, 6)
    # Per spacecraft and epoch, how many of its six axes lie within 2 and 3 sigma (whole numbers: any sum of
    # them is exact, so a share is the same number however it is added up).
    within = {limit: np.ascontiguousarray(_count_of_six((ratio <= limit).view(np.uint8)).T) for limit in (2.0, 3.0)}
    nees_columns = _nees_columns(nees, n_nees, settled)  # the whole state's: the same in every row
    rows = []
    for i, name in enumerate(spacecraft):
        row = {
            "spacecraft": name,
            "rms_position_m": rms(after_t0.of(columns.row("position_error_m", i))),
            "rms_velocity_m_s": rms(after_t0.of(columns.row("velocity_error_m_s", i))),
            "rms_position_after_day1_m": rms(late.of(columns.row("position_error_m", i))),
            "rms_velocity_after_day1_m_s": rms(late.of(columns.row("velocity_error_m_s", i))),
            "frac_in_2sigma": _share(within[2.0][i], after_t0),
            "frac_in_3sigma": _share(within[3.0][i], after_t0),
            "frac_in_2sigma_after_day1": _share(within[2.0][i], late),
            "frac_in_3sigma_after_day1": _share(within[3.0][i], late),
            **_error_and_sigma(columns, settled, i, "settled"),
            **nees_columns,
        }
        rows.append(row)
        if 0 <= data_end_step < len(times_s) - 1:
            ahead = _Epochs(np.arange(len(times_s)) > data_end_step)
            rows[-1]["rms_position_prediction_m"] = rms(ahead.of(columns.row("position_error_m", i)))
            rows[-1]["rms_velocity_prediction_m_s"] = rms(ahead.of(columns.row("velocity_error_m_s", i)))
    return rows, norms


def _count_of_six(flags):
    """(..., 6) uint8 0/1 -> (...) their count (six slices added: a reduction over a short axis costs 10x more)."""
    return flags[..., 0] + flags[..., 1] + flags[..., 2] + flags[..., 3] + flags[..., 4] + flags[..., 5]


def _share(axes_within, epochs) -> float:
    """The share of (epoch, axis) samples within the bound over the epochs, from each epoch's count of its six
    axes; NaN for no epochs."""
    selected = epochs.of(axes_within)
    return float(selected.sum() / (6 * selected.size)) if selected.size else float("nan")


@lru_cache(maxsize=1024)  # every run asks for the same few quantiles
def chi2_quantile(probability: float, dof: float) -> float:
    """The chi-square quantile with `dof` degrees of freedom: x with P(dof / 2, x / 2) = probability, P the
    regularised lower incomplete gamma function. Pure Python: importing scipy.special cost 50 ms at every
    start. Against scipy.stats.chi2.ppf (tests/unit/estimation/test_engine_parts.py): within 1e-11 relative for 1 to 120,000
    degrees of freedom and probabilities 1e-6 to 1 - 1e-6; within 1e-11 up to 1e7 degrees of freedom at the
    probabilities liaison asks for (0.025, 0.975, 0.999)."""
    if not 0.0 < probability < 1.0 or dof <= 0.0:
        raise ValueError(f"chi2_quantile: probability {probability} must be in (0, 1) and dof {dof} positive")
    a = 0.5 * dof
    upper = probability > 0.5  # solve on the smaller tail, where the function has its digits
    target = 1.0 - probability if upper else probability
    z = NormalDist().inv_cdf(probability)  # Wilson-Hilferty start
    h = 2.0 / (9.0 * dof)
    x = 0.5 * dof * max(1.0 - h + z * math.sqrt(h), 0.05) ** 3
    low, high = 0.0, math.inf  # a bracket in x (half the chi-square value) kept by every step
    for _ in range(100):
        lower_p, upper_q = _regularised_gamma(a, x)
        value = (upper_q if upper else lower_p) - target
        if (value > 0.0) != upper:  # P too large (or Q too small): the root lies below x
            high = x
        else:
            low = x
        density = math.exp((a - 1.0) * math.log(x) - x - math.lgamma(a))  # dP/dx
        step = value / density if not upper else -value / density
        candidate = x - step
        if not low < candidate < high:  # Newton left the bracket: bisect
            candidate = 0.5 * (low + high) if math.isfinite(high) else 2.0 * x
        if abs(candidate - x) <= 1e-15 * x:
            x = candidate
            break
        x = candidate
    return 2.0 * x


def _regularised_gamma(a: float, x: float) -> tuple[float, float]:
    """(P(a, x), Q(a, x)) = regularised lower and upper incomplete gamma functions: the series below
    x = a + 1, Lentz's continued fraction for Q above (Numerical Recipes' split)."""
    if x <= 0.0:
        return 0.0, 1.0
    log_prefactor = a * math.log(x) - x - math.lgamma(a)
    if x < a + 1.0:
        term = total = 1.0 / a
        n = 1
        while abs(term) > 1e-17 * abs(total):
            term *= x / (a + n)
            total += term
            n += 1
        lower = total * math.exp(log_prefactor)
        return lower, 1.0 - lower
    tiny = 1e-300
    b = x + 1.0 - a
    c = 1.0 / tiny
    d = 1.0 / b
    fraction = d
    n = 1
    while True:
        an = -n * (n - a)
        b += 2.0
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1.0 / d
        delta = d * c
        fraction *= delta
        n += 1
        if abs(delta - 1.0) < 1e-16 or n > 100_000:
            break
    upper = math.exp(log_prefactor) * fraction
    return 1.0 - upper, upper


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
    counts = np.concatenate([[0], np.cumsum(above)])  # whole numbers: exact
    full = np.flatnonzero(counts[window_steps:] - counts[:-window_steps] == window_steps)
    return int(full[0]) + window_steps if full.size else -1  # the window ending there ends at epoch j + window
