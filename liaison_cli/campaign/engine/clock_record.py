"""A run's clock record (clocks.parquet): the estimated clocks' errors and sigmas from the filter's history, or,
with clock_sync (002 §4) and no clock states, each clock-offset link's fitted clock over the sync window and the
prediction, and the clocks' names in the record's order."""

import numpy as np

from liaison_cli.dynamics.constants import M_PER_LU
from liaison_cli.estimation.clock_sync import sync_errors
from liaison_cli.scenario.setup import SPEED_OF_LIGHT_M_S, Problem


def add_clock_sync(problem: Problem, clock_phase_s: dict, y_obs, data_end_step: int, summary):
    """clock_sync (002 §4): fit each clock-offset channel over the window that ends where the estimator's data
    end, and put the RMS against the true offset (ns) over the window and over the prediction after it into
    the row of the link's far end (its clock relative to the link's receiver, the main spacecraft). Returns the
    fits' histories as the clocks table takes them, (m, L, 2) errors and 1-sigmas in s and s/s, one clock per
    clock-offset channel (clock_record_names), over the window and the prediction (NaN elsewhere): the phase
    against the true offset, the frequency (the fit's rate) against the true offset's central difference over
    the neighbouring epochs; (None, None) without clock_sync."""
    spec = problem.scenario.clock_sync
    if spec is None:
        return None, None
    times_s = problem.times_s
    end_s = float(times_s[data_end_step])
    rows = {row["spacecraft"]: row for row in summary}
    to_s = M_PER_LU / SPEED_OF_LIGHT_M_S
    channels = [c for c, ch in enumerate(problem.channels) if ch.measures_clock_offset]
    error, spread = np.full((len(times_s), len(channels), 2), np.nan), np.full((len(times_s), len(channels), 2), np.nan)
    for j, c in enumerate(channels):
        link = problem.scenario.links[problem.channels[c].link]
        true_s = clock_phase_s[link.receiver] - clock_phase_s[link.transponder]
        window_s, prediction_s = spec.window_hours * 3600.0, spec.prediction_hours * 3600.0
        result = sync_errors(times_s, y_obs[:, c] * to_s, true_s, problem.sigma_lu[c] * to_s, end_s,
                             window_s, prediction_s, spec.degree)
        row = rows.get(link.transponder)
        if row is not None and "clock_rms_window_ns" not in row:
            row["clock_rms_window_ns"] = 1e9 * result["rms_window_s"]
            row["clock_rms_prediction_ns"] = 1e9 * result["rms_prediction_s"]
        shown = (times_s > end_s - window_s - 1e-9) & (times_s <= end_s + prediction_s + 1e-9)
        fitted_error, fitted_sigma = fitted_clock_errors(result["fit"], times_s, true_s)
        error[shown, j], spread[shown, j] = fitted_error[shown], fitted_sigma[shown]
    return error, spread


def fitted_clock_errors(fit, times_s, true_s):
    """(m, 2) phase and frequency errors of a clock fit (estimation.clock_sync.ClockFit) and their 1-sigmas."""
    dt = np.asarray(times_s, dtype=float) - fit.t_ref_s
    degree = len(fit.coefficients) - 1
    value = np.vander(dt, degree + 1, increasing=True)
    rate = np.zeros_like(value)
    rate[:, 1:] = value[:, :-1] * np.arange(1, degree + 1)
    errors = np.column_stack([value @ fit.coefficients - true_s, rate @ fit.coefficients - np.gradient(true_s, times_s)])
    sigmas = np.column_stack([np.sqrt(np.einsum("ki,ij,kj->k", value, fit.covariance, value)),
                              np.sqrt(np.einsum("ki,ij,kj->k", rate, fit.covariance, rate))])
    return errors, sigmas


def clock_record_names(problem: Problem) -> list[str]:
    """The clocks of a run's clock record, in its order: the estimated clocks' owners, else (clock_sync) the far
    end of each clock-offset channel's link, whose clock is measured relative to the link's receiver ("FAR vs
    RECEIVER" when that far end is measured from more than one receiver)."""
    estimated = [c.owner for c in problem.clocks if c.state_start >= 0]
    if estimated or problem.scenario.clock_sync is None:
        return estimated
    links = [problem.scenario.links[ch.link] for ch in problem.channels if ch.measures_clock_offset]
    far_ends = [link.transponder for link in links]
    # A far end measured from two receivers (a mesh) is two clock offsets: each named with its receiver.
    return [end if far_ends.count(end) == 1 else f"{end} vs {link.receiver}" for end, link in zip(far_ends, links)]


def estimated_clock_histories(problem: Problem, err, sigma):
    """Each estimated clock's phase / frequency error and 1-sigma in seconds and s/s: (m, n_clocks, 2) x2."""
    if not problem.clocks:
        return None, None
    columns = [(c.state_start, np.array(c.scale)) for c in problem.clocks if c.state_start >= 0]
    if not columns:
        return None, None
    error = np.stack([err[:, a : a + 2] / scale for a, scale in columns], axis=1)
    spread = np.stack([sigma[:, a : a + 2] / scale for a, scale in columns], axis=1)
    return error, spread
