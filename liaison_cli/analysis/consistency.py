"""Is the filter's sigma the truth about its error? Consistency by direction, and one verdict for every report.

By direction (from the EKF's `estimation.kernel_args.DirectionRecord`, after the settle time):
- each spacecraft's own 6-state NEES, against the chi-square band of 6 degrees of freedom;
- the common time shift, u the true states' rate of change (all spacecraft at once). With P = L L' and the
  whitened error w = L^-1 e (NEES = |w|^2), the component of w along L^-1 u, c = u'P^-1 e / sqrt(u'P^-1 u):
  the information-weighted size of an error of shape u in its sigma (N(0, 1) when consistent; not the plain
  projection u'e / sqrt(u'Pu)), and c^2 that direction's share of the NEES (the shares of orthogonal whitened
  directions add up to the NEES). A filter that tags the measurements at the
  wrong epoch (001's geometric range against a light-time truth) lags along u: mean c is its bias in sigma,
  and the lag that fits the errors best is given in seconds;
- the line of sight of each linked pair (relative position along the link), the same two numbers.
A 3-D error / sigma ratio can read "conservative" while one such direction is several sigma off: the
direction with the largest NEES is named in the run text.

The verdict (`verdict`), the same for a run and for a campaign of runs: consistent when
1. the NEES test passes: at least NEES_REQUIRED_SHARE of the settled (run, epoch) samples of the whole-state
   NEES, and of each spacecraft's 6-state NEES, lie in their single-run two-sided 95 % chi-square bands
   (a consistent filter puts 95 % there; too few means optimistic where above, pessimistic where below);
2. the error / sigma ratio test passes: the 95 % confidence interval of the campaign ratio (from the spread of
   the runs; a point with one run) reaches [1 / RATIO_LIMIT, RATIO_LIMIT]; too conservative fails as well as
   too optimistic.
`consistency_failed` says which test failed and how.
"""

import math

import numpy as np

from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT, campaign_error_to_sigma, fraction, nees_run_band

NEES_REQUIRED_SHARE = 0.85  # a matched filter measured 89.9 % per spacecraft (30 runs, test_consistency); 95 % expected
RATIO_LIMIT = CONSISTENCY_RATIO_LIMIT
CONFIDENCE_Z = 1.96  # two-sided 95 % normal quantile for the ratio's interval
SPACECRAFT_STATES = 6


def direction_columns(times_s, directions, settle_s: float, n_spacecraft: int, pair_names, interval_s: float):
    """(per-spacecraft dicts (n_spacecraft), one dict for the run) after settle_s from a DirectionRecord:
    frac_nees_spacecraft_in_band_settled / _above_ and mean_nees_spacecraft_settled per spacecraft;
    time_shift_nees_settled (the whole-state NEES's mean component along the time shift: 1 when consistent),
    time_shift_bias_sigma_settled (the mean error along it in its sigma) and time_shift_lag_s_settled (the lag
    of the estimate behind the truth that fits the settled errors best, s); the same two numbers along the
    line of sight of the linked pair whose component is largest (named in along_link_pair). NaN where not
    recorded (an estimator other than the EKF, a run without linked estimated pairs)."""
    times_s = np.asarray(times_s)
    if directions is not None:  # the recorded epochs (every stride-th of the EKF's) after the settle time
        first = int(np.searchsorted(times_s, settle_s))
        recorded = directions.covariance[first:, 0, 0] if directions.covariance.shape[1] else np.zeros(0)
        settled = first + np.flatnonzero(np.isfinite(recorded))
    low, high = nees_run_band(SPACECRAFT_STATES)
    per_spacecraft = []
    for s in range(n_spacecraft):
        values = _finite(directions.nees_spacecraft[settled, s]) if directions is not None else np.zeros(0)
        per_spacecraft.append({
            "frac_nees_spacecraft_in_band_settled": fraction((values >= low) & (values <= high)),
            "frac_nees_spacecraft_above_band_settled": fraction(values > high),
            "mean_nees_spacecraft_settled": float(np.mean(values)) if values.size else float("nan"),
        })
    run = {"time_shift_nees_settled": float("nan"), "time_shift_bias_sigma_settled": float("nan"),
           "time_shift_lag_s_settled": float("nan"), "along_link_pair": "", "along_link_nees_settled": float("nan"),
           "along_link_bias_sigma_settled": float("nan")}
    if directions is None:
        return per_spacecraft, run
    shift = directions.time_shift[settled]
    run["time_shift_nees_settled"], run["time_shift_bias_sigma_settled"] = _component(shift[:, 0], shift[:, 1])
    ok = np.isfinite(shift[:, 0]) & (shift[:, 1] > 0)
    if np.any(ok):  # the lag d (steps) with e = -d u fitting all settled epochs: -sum v'z / sum v'v
        run["time_shift_lag_s_settled"] = float(-np.sum(shift[ok, 0]) / np.sum(shift[ok, 1]) * interval_s)
    for p, name in enumerate(pair_names):
        pair = directions.along_pair[settled, p]
        nees, bias = _component(pair[:, 0], pair[:, 1])
        if np.isfinite(nees) and not nees <= run["along_link_nees_settled"]:
            run.update(along_link_pair=name, along_link_nees_settled=nees, along_link_bias_sigma_settled=bias)
    return per_spacecraft, run


def _finite(values) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    return values[np.isfinite(values)]


def _component(projected, length) -> tuple[float, float]:
    """(mean c^2, mean c), c = v'z / |v| the whitened error along a direction, over the finite samples."""
    projected, length = np.asarray(projected, dtype=float), np.asarray(length, dtype=float)
    ok = np.isfinite(projected) & (length > 0)
    if not np.any(ok):
        return float("nan"), float("nan")
    c = projected[ok] / np.sqrt(length[ok])
    return float(np.mean(c * c)), float(np.mean(c))


def ratio_interval(error_rms, sigma_rms) -> tuple[float, float]:
    """(campaign ratio sqrt(mean e^2 / mean s^2), half-width of its 95 % interval) from the runs' settled error
    and sigma RMS, paired run by run (a run missing either is left out): the delta method on the ratio of
    means. With one run there is no spread to measure: the half-width is 0 (a point test, as a run's own)."""
    error_rms, sigma_rms = np.asarray(error_rms, dtype=float), np.asarray(sigma_rms, dtype=float)
    both = np.isfinite(error_rms) & np.isfinite(sigma_rms) if error_rms.shape == sigma_rms.shape else None
    if both is None:
        return float("nan"), math.inf
    e2, s2 = np.square(error_rms[both]), np.square(sigma_rms[both])
    ratio = campaign_error_to_sigma(np.sqrt(e2), np.sqrt(s2))
    n = e2.size
    if not math.isfinite(ratio) or ratio <= 0:
        return ratio, math.inf
    if n < 2:
        return ratio, 0.0
    squared = ratio * ratio
    variance = np.var(e2 - squared * s2, ddof=1) / (n * np.mean(s2) ** 2)  # of mean e^2 / mean s^2
    return ratio, CONFIDENCE_Z * math.sqrt(max(variance, 0.0)) / (2.0 * ratio)


def verdict(shares: dict, ratios: dict) -> tuple[bool, str]:
    """(consistent, what failed) from shares = {label: (share in band, share above band)} of NEES samples
    (whole state, each spacecraft) and ratios = {label: (ratio, half-width of its interval)}."""
    failed = []
    for label, (inside, above) in shares.items():
        if not inside >= NEES_REQUIRED_SHARE:
            below = max(1.0 - inside - above, 0.0)  # not -0.0 % when the rest rounds to nothing
            side = "optimistic" if above >= below else "pessimistic"
            failed.append(f"{label} NEES in band {_percent(inside)} < {_percent(NEES_REQUIRED_SHARE)} "
                          f"(above {_percent(above)}, below {_percent(below)}: {side})")
    for label, (ratio, half_width) in ratios.items():
        if not math.isfinite(ratio):
            failed.append(f"{label} err/sigma not available")
        elif ratio - half_width > RATIO_LIMIT:
            failed.append(f"{label} err/sigma {_interval(ratio, half_width)} > {RATIO_LIMIT:g}: optimistic")
        elif ratio + half_width < 1.0 / RATIO_LIMIT:
            failed.append(f"{label} err/sigma {_interval(ratio, half_width)} < {1.0 / RATIO_LIMIT:.2f}: pessimistic")
    return not failed, "; ".join(failed)


def _percent(share: float) -> str:
    return "n/a" if not math.isfinite(share) else f"{100.0 * share:.1f} %"


def _interval(ratio: float, half_width: float) -> str:
    return f"{ratio:.2f} +- {half_width:.2f}" if 0.0 < half_width < math.inf else f"{ratio:.2f}"


def campaign_verdict(rows) -> dict:
    """One spacecraft's campaign verdict from its runs' rows (a DataFrame of the summary columns, finished runs
    only): the campaign ratios with their interval half-widths, the mean NEES shares and consistent_settled /
    consistency_failed (verdict)."""
    out, ratios = {}, {}
    for kind, unit in (("position", "m"), ("velocity", "m_s")):
        ratio, half_width = ratio_interval(_column(rows, f"rms_{kind}_settled_{unit}"),
                                           _column(rows, f"sigma_{kind}_settled_{unit}"))
        out[f"{kind}_error_to_sigma_settled"], out[f"{kind}_error_to_sigma_halfwidth"] = ratio, half_width
        ratios[kind] = (ratio, half_width)
    shares = {}
    for label, prefix in (("state", "frac_nees"), ("spacecraft", "frac_nees_spacecraft")):
        inside = _mean(_column(rows, f"{prefix}_in_band_settled"))
        above = _mean(_column(rows, f"{prefix}_above_band_settled"))
        out[f"{prefix}_in_band_settled"], out[f"{prefix}_above_band_settled"] = inside, above
        if math.isfinite(inside):
            shares[label] = (inside, above)
    out["consistent_settled"], out["consistency_failed"] = verdict(shares, ratios)
    return out


def _column(rows, name: str) -> np.ndarray:
    return np.asarray(rows[name], dtype=float) if name in rows else np.zeros(0)


def _mean(values) -> float:
    values = _finite(values)
    return float(np.mean(values)) if values.size else float("nan")


def run_verdict(row: dict) -> tuple[bool, str]:
    """One run's verdict for one spacecraft row: its NEES shares and its own settled ratios (no interval)."""
    shares = {label: (row[f"{prefix}_in_band_settled"], row.get(f"{prefix}_above_band_settled", float("nan")))
              for label, prefix in (("state", "frac_nees"), ("spacecraft", "frac_nees_spacecraft"))
              if math.isfinite(row.get(f"{prefix}_in_band_settled", float("nan")))}
    ratios = {kind: (row[f"{kind}_error_to_sigma_settled"], 0.0) for kind in ("position", "velocity")}
    return verdict(shares, ratios)


def failed_side(failed: str) -> str:
    """optimistic when any failed test of the verdict (verdict's text, one test per
    '; '-separated part, each ending in its side) is optimistic, else pessimistic; '' when no test names a side
    (a ratio not available)."""
    sides = {part.rsplit(":", 1)[-1].strip(" )") for part in failed.split("; ")}
    if "optimistic" in sides:
        return "optimistic"
    return "pessimistic" if "pessimistic" in sides else ""
