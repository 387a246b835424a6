"""004's study: each transmitter scenario (scenarios/004/*.yaml) run once per receiver pair (one link each).

Per transmitter and pair:
- 3-sigma histories of the position and velocity error norms from the filter's covariance along the true
  trajectory (LinCov with the filter's own gains, campaign.error_budget): the uncertainty 004 plots, the
  same whether or not an EKF run started 1,000 km off finds the orbit;
- the EKF Monte Carlo beside it (_monte_carlo): the share of runs that converged and when (two readings),
  and over the converged runs the error RMS against the sigma RMS after the settle time and over the last
  quarter, with the NEES-in-band share: whether the EKF reaches the covariance LinCov promises, and whether
  its sigma can be trusted there. LinCov starts from the a priori at t0; an EKF with an initial batch
  (filter.initial_batch_hours) starts from the batch's hand-over;
- steady state: the median LinCov 3-sigma bound over the last quarter of the arc (before the first manoeuvre
  where there is one: judged_until_day);
- days below 1 km / 1 cm/s: from when the 3-sigma bound stays below 004's yardsticks;
- convergence time: the first epoch from which the position 3-sigma bound stays below twice its steady
  state for the rest of the arc;
- `rankings`: per transmitter (and grid point, e.g. an SNC sensitivity through `--grid`), the pairs best
  first by LinCov and by the EKF, so a ranking that flips with the tuning shows;
- DOP (004 §4) along the true geometry: sqrt(trace(pinv(H' H))) with H the TDoA path partials with respect
  to the transmitter's position (one pair: 1 / |dTDoA/dr|, in metres of path per metre), its median over
  the epochs that have a measurement, and the share of such epochs.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.analysis.dop import tdoa_dop
from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.campaign.error_budget import error_budget
from liaison_cli.campaign.backends import LOCAL, Backend, session
from liaison_cli.campaign.runner import run_campaign
from liaison_cli.campaign.study_cells import CellStore, grid_points, source_digest
from liaison_cli.campaign.study003 import StudyError
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.scenario.schema import Scenario, apply_overrides


def pair_name(link) -> str:
    return f"{link.receiver}+{link.second_receiver}"


def pair_scenario(scenario: Scenario, transmitter: str, index: int) -> Scenario:
    link = scenario.links[index]
    return apply_overrides(scenario, {"links": [link.model_dump(exclude_none=True)],
                                      "name": f"{transmitter}_{link.receiver}-{link.second_receiver}"},
                           f"{transmitter} ({pair_name(link)})")


def first_day_staying_below(t_days, bound, limit) -> float:
    """First time from which `bound` stays below `limit`; NaN if it never settles."""
    above = np.flatnonzero(~(bound <= limit))
    if len(above) == 0:
        return float(t_days[0])
    last = above[-1]
    return float(t_days[last + 1]) if last + 1 < len(t_days) else float("nan")


def _statistics(campaign, transmitter: str, pair: str):
    problem = campaign.problem
    t_days = problem.times_s / SECONDS_PER_DAY
    row = {"transmitter": transmitter, "pair": pair}
    history = {"transmitter": transmitter, "pair": pair, "t_days": t_days}
    arc = t_days < judged_until_day(problem.scenario, t_days)
    quarter = arc & (t_days >= 0.75 * t_days[arc][-1])
    lincov_variance = error_budget(problem).filter_variance[:, 0, :]  # the filter's P along the truth
    steady = {}
    for column, (kind, unit) in enumerate((("position", "m"), ("velocity", "m_s"))):
        bound = 3.0 * np.sqrt(lincov_variance[:, column])
        history[f"{kind}_3sigma_{unit}"] = bound
        steady[kind] = float(np.median(bound[quarter]))
        row[f"steady_3sigma_{kind}_{unit}"] = steady[kind]
        row[f"convergence_days_{kind}"] = first_day_staying_below(t_days[arc], bound[arc], 2.0 * steady[kind])
        yardstick = ("1km", 1e3) if kind == "position" else ("1cm_s", 1e-2)  # 004's: 1 km and 1 cm/s
        row[f"days_below_{yardstick[0]}"] = first_day_staying_below(t_days[arc], bound[arc], yardstick[1])
    row["judged_until_day"] = float(t_days[arc][-1])
    row.update(_monte_carlo(campaign, t_days, arc, quarter, steady["position"], history))
    measured = np.isfinite(problem.measurements_true[1:, 0])
    dop = _dop(problem)
    row["measured_share"] = float(measured.mean())
    row["median_dop"] = float(np.median(dop[1:][measured])) if measured.any() else float("nan")
    history["dop"] = dop
    history["measured"] = np.r_[False, measured]
    return row, pd.DataFrame(history)


def judged_until_day(scenario: Scenario, t_days) -> float:
    """Steady state and convergence are judged before the first manoeuvre (its a-priori error resets the
    uncertainty; 004's transfer is judged before its burn), else over the whole arc: the first day past it."""
    burns = [sc.manoeuvre.epoch_days for sc in scenario.spacecraft if sc.manoeuvre is not None]
    return min(burns) if burns else float(t_days[-1]) + 1.0


def _monte_carlo(campaign, t_days, arc, quarter, steady_position_3sigma_m: float, history: dict) -> dict:
    """The EKF's Monte Carlo beside LinCov. A run has converged at the first epoch from which its position error
    stays below twice LinCov's steady 3-sigma until the end of the judged arc (the convergence rule LinCov's
    own row uses, applied to the error) and not before its initial batch hands over (a batch solution is a smoothed estimate: not available
    in real time before the window closes); 004's reading: from when the error stays below 1 km. Converged
    share: runs with such an epoch among all runs (a run that diverged, failed or never settles has not).
    Consistency over the converged runs: error RMS, sigma RMS and their ratio after the scenario's settle time
    and over the last quarter, and the share of settled epochs whose NEES lies in its 95 % band."""
    problem = campaign.problem
    outcomes = campaign.outcomes
    ok = [o for o in outcomes if o.status == "ok"]
    out = {"runs": len(outcomes), "runs_ok": len(ok)}
    converged, days, days_1km, windows = [], [], [], []
    for o in ok:
        error = o.norms["position_error_m"][:, 0]
        handover = o.summary[0].get("initial_batch_window_h", 0.0) / 24.0
        windows.append(handover)
        first = max(first_day_staying_below(t_days[arc], error[arc], 2.0 * steady_position_3sigma_m), handover)
        if np.isfinite(first):
            converged.append(o)
            days.append(first)
            days_1km.append(max(first_day_staying_below(t_days[arc], error[arc], 1e3), handover))
    out["ekf_converged_share"] = len(converged) / len(outcomes) if outcomes else float("nan")
    out["ekf_converged_days_median"] = float(np.median(days)) if days else float("nan")
    out["ekf_converged_days_max"] = float(np.max(days)) if days else float("nan")
    finite_1km = [d for d in days_1km if np.isfinite(d)]
    out["ekf_below_1km_days_median"] = float(np.median(finite_1km)) if finite_1km else float("nan")
    out["ekf_initial_batch_window_days_median"] = float(np.median(windows)) if windows else float("nan")
    settled = problem.times_s >= problem.scenario.settle_days() * SECONDS_PER_DAY
    for kind, unit in (("position", "m"), ("velocity", "m_s")):
        if converged:
            err = np.array([o.norms[f"{kind}_error_{unit}"][:, 0] for o in converged])
            sigma = np.array([o.norms[f"{kind}_3sigma_{unit}"][:, 0] for o in converged]) / 3.0
            history[f"{kind}_ekf_3sigma_{unit}"] = 3.0 * np.sqrt(np.mean(sigma**2, axis=0))
            history[f"{kind}_ekf_error_rms_{unit}"] = np.sqrt(np.mean(err**2, axis=0))
        else:
            err = sigma = np.full((0, len(t_days)), np.nan)
            history[f"{kind}_ekf_3sigma_{unit}"] = np.nan
            history[f"{kind}_ekf_error_rms_{unit}"] = np.nan
        for label, epochs in (("settled", settled), ("last_quarter", quarter)):
            error_rms = float(np.sqrt(np.mean(err[:, epochs] ** 2))) if converged else float("nan")
            sigma_rms = float(np.sqrt(np.mean(sigma[:, epochs] ** 2))) if converged else float("nan")
            out[f"ekf_error_rms_{kind}_{label}_{unit}"] = error_rms
            out[f"ekf_sigma_rms_{kind}_{label}_{unit}"] = sigma_rms
            out[f"ekf_error_to_sigma_{kind}_{label}"] = error_rms / sigma_rms if sigma_rms > 0 else float("nan")
    shares = [row["frac_nees_in_band_settled"] for o in converged for row in o.summary[:1]]
    out["ekf_frac_nees_in_band_settled"] = float(np.mean(shares)) if shares else float("nan")
    verdict = campaign_verdict(pd.DataFrame([o.summary[0] for o in converged]))
    out["ekf_consistent_settled"] = bool(converged) and verdict["consistent_settled"]
    out["ekf_consistency_failed"] = verdict["consistency_failed"] if converged else "no run converged"
    return out


def _dop(problem) -> np.ndarray:
    """DOP of the (only) pair along the true geometry, (m,)."""
    f = problem.filter
    ends = f.channel_ends[0]
    transmitter = problem.truth[:, ends[2] : ends[2] + 3] if ends[2] >= 0 else f.known_states[:, ends[3], :3]
    first = f.known_states[:, ends[1], :3] if ends[0] < 0 else problem.truth[:, ends[0] : ends[0] + 3]
    second = f.known_states[:, ends[5], :3] if ends[4] < 0 else problem.truth[:, ends[4] : ends[4] + 3]
    return tdoa_dop(first, transmitter, second)


def _pair_tables(scenario: Scenario, transmitter: str, pair: str, runs: int, jobs: int, progress: bool,
                 truth_cache: dict, where: Backend) -> dict:
    campaign = run_campaign(scenario, runs=runs, jobs=jobs, progress=progress, description=f"{transmitter} {pair}",
                            truth_cache=truth_cache, where=where)
    row, history = _statistics(campaign, transmitter, pair)
    return {"summary": pd.DataFrame([row]), "history": history}


def run_study(transmitters: list[tuple[str, Scenario]], runs: int, jobs: int = 2, progress: bool = True,
              grid: list[tuple[str, list]] | None = None, where: Backend = LOCAL, work: Path | None = None):
    """(summary, histories): one row / history per grid point, transmitter and receiver pair. A grid point is
    a dict of overrides (apply_overrides keys, e.g. filter.process_noise_accel_m_s2) applied to every
    transmitter's scenario; grid keys become columns. A transmitter's pairs share its trajectories
    (propagated and corrected once) across pairs and grid points. `work`: the folder of finished cells
    (study_cells): an interrupted study started again computes only the cells missing there."""
    points = grid_points(grid)
    store = CellStore(work, "study004", source_digest(__file__))
    rows, histories = [], []
    cells = len(points) * sum(len(scenario.links) for _, scenario in transmitters)
    with store.saving_on_interrupt(cells), session(where, jobs):  # session: one dask cluster for every cell
        for transmitter, scenario in transmitters:
            if not all(link.second_receiver is not None for link in scenario.links):
                raise StudyError(f"{scenario.name}: 004's study runs receiver pairs: every link needs a "
                                 "second_receiver")
            shared: dict = {}
            for index, point in enumerate(points):
                base = apply_overrides(scenario, point, f"{transmitter} {point}") if point else scenario
                for link_index, link in enumerate(base.links):
                    one_pair = pair_scenario(base, transmitter, link_index)
                    tables = store.cell(f"p{index}_{transmitter}_{pair_name(link)}", one_pair, runs,
                                        lambda: _pair_tables(one_pair, transmitter, pair_name(link), runs, jobs,
                                                             progress, shared, where))
                    row, history = tables["summary"].to_dict("records")[0], tables["history"]
                    for key, value in point.items():
                        row[key] = value
                        history[key] = value
                    rows.append(row)
                    histories.append(history)
    return pd.DataFrame(rows), pd.concat(histories, ignore_index=True)


def rankings(summary: pd.DataFrame, grid_keys: list[str]) -> pd.DataFrame:
    """Per grid point and transmitter, the receiver pairs ordered best first by LinCov's steady 3-sigma
    position and by the EKF's settled error RMS (converged runs), and whether the two orders agree: where a
    ranking flips with the tuning, the table shows it."""
    rows = []
    group_keys = grid_keys + ["transmitter"]
    for keys, part in summary.groupby(group_keys, sort=False):
        keys = keys if isinstance(keys, tuple) else (keys,)
        by_lincov = list(part.sort_values("steady_3sigma_position_m").pair)
        ekf = part[np.isfinite(part.ekf_error_rms_position_settled_m)]
        by_ekf = list(ekf.sort_values("ekf_error_rms_position_settled_m").pair)
        rows.append({**dict(zip(group_keys, keys)), "best_first_lincov": " < ".join(by_lincov),
                     "best_first_ekf": " < ".join(by_ekf) if len(by_ekf) == len(part) else "—"})
    return pd.DataFrame(rows)
