"""004's study: each transmitter scenario (scenarios/004/*.yaml) run once per receiver pair (one link each).

Per transmitter and pair:
- 3-sigma histories of the position and velocity error norms from the filter's covariance along the true
  trajectory (LinCov with the filter's own gains, campaign.error_budget): the uncertainty 004 plots, the
  same whether or not an EKF run started 1,000 km off finds the orbit;
- the EKF Monte Carlo beside it: runs that finished, their mean 3-sigma and error RMS, and the share of
  epochs inside 3-sigma;
- steady state: the median LinCov 3-sigma bound over the last quarter of the arc;
- days below 1 km / 1 cm/s: from when the 3-sigma bound stays below 004's yardsticks;
- convergence time: the first epoch from which the position 3-sigma bound stays below twice its steady
  state for the rest of the arc;
- DOP (004 §4) along the true geometry: sqrt(trace(pinv(H' H))) with H the TDoA path partials with respect
  to the transmitter's position (one pair: 1 / |dTDoA/dr|, in metres of path per metre), its median over
  the epochs that have a measurement, and the share of such epochs.
"""

import numpy as np
import pandas as pd

from liaison_cli.analysis.dop import tdoa_dop
from liaison_cli.campaign.error_budget import error_budget
from liaison_cli.campaign.runner import run_campaign
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
    ok = [o for o in campaign.outcomes if o.status == "ok"]
    t_days = problem.times_s / SECONDS_PER_DAY
    row = {"transmitter": transmitter, "pair": pair, "runs": len(campaign.outcomes), "runs_ok": len(ok)}
    history = {"transmitter": transmitter, "pair": pair, "t_days": t_days}
    quarter = t_days >= 0.75 * t_days[-1]
    lincov_variance = error_budget(problem).filter_variance[:, 0, :]  # the filter's P along the truth
    for column, (kind, unit) in enumerate((("position", "m"), ("velocity", "m_s"))):
        bound = 3.0 * np.sqrt(lincov_variance[:, column])
        history[f"{kind}_3sigma_{unit}"] = bound
        steady = float(np.median(bound[quarter]))
        row[f"steady_3sigma_{kind}_{unit}"] = steady
        row[f"convergence_days_{kind}"] = first_day_staying_below(t_days, bound, 2.0 * steady)
        yardstick = ("1km", 1e3) if kind == "position" else ("1cm_s", 1e-2)  # 004's: 1 km and 1 cm/s
        row[f"days_below_{yardstick[0]}"] = first_day_staying_below(t_days, bound, yardstick[1])
        if ok:
            err = np.array([o.norms[f"{kind}_error_{unit}"][:, 0] for o in ok])
            mc_bound = np.array([o.norms[f"{kind}_3sigma_{unit}"][:, 0] for o in ok])
            history[f"{kind}_ekf_3sigma_{unit}"] = mc_bound.mean(axis=0)
            history[f"{kind}_ekf_error_rms_{unit}"] = np.sqrt(np.mean(err**2, axis=0))
            row[f"ekf_inside_3sigma_{kind}"] = float(np.mean(err[:, 1:] <= mc_bound[:, 1:]))
            row[f"ekf_error_rms_last_quarter_{kind}_{unit}"] = float(np.sqrt(np.mean(err[:, quarter] ** 2)))
        else:
            history[f"{kind}_ekf_3sigma_{unit}"] = np.nan
            history[f"{kind}_ekf_error_rms_{unit}"] = np.nan
            row[f"ekf_inside_3sigma_{kind}"] = np.nan
            row[f"ekf_error_rms_last_quarter_{kind}_{unit}"] = np.nan
    measured = np.isfinite(problem.measurements_true[1:, 0])
    dop = _dop(problem)
    row["measured_share"] = float(measured.mean())
    row["median_dop"] = float(np.median(dop[1:][measured])) if measured.any() else float("nan")
    history["dop"] = dop
    history["measured"] = np.r_[False, measured]
    return row, pd.DataFrame(history)


def _dop(problem) -> np.ndarray:
    """DOP of the (only) pair along the true geometry, (m,)."""
    f = problem.filter
    ends = f.channel_ends[0]
    transmitter = problem.truth[:, ends[2] : ends[2] + 3] if ends[2] >= 0 else f.known_states[:, ends[3], :3]
    first = f.known_states[:, ends[1], :3] if ends[0] < 0 else problem.truth[:, ends[0] : ends[0] + 3]
    second = f.known_states[:, ends[5], :3] if ends[4] < 0 else problem.truth[:, ends[4] : ends[4] + 3]
    return tdoa_dop(first, transmitter, second)


def run_study(transmitters: list[tuple[str, Scenario]], runs: int, jobs: int = 2, progress: bool = True):
    """(summary, histories): one row / history per transmitter and receiver pair. A transmitter's pairs share
    its trajectories (propagated and corrected once)."""
    rows, histories = [], []
    for transmitter, scenario in transmitters:
        if not all(link.second_receiver is not None for link in scenario.links):
            raise StudyError(f"{scenario.name}: 004's study runs receiver pairs: every link needs a second_receiver")
        shared: dict = {}
        for index, link in enumerate(scenario.links):
            campaign = run_campaign(pair_scenario(scenario, transmitter, index), runs=runs, jobs=jobs,
                                    progress=progress, description=f"{transmitter} {pair_name(link)}",
                                    truth_cache=shared)
            row, history = _statistics(campaign, transmitter, pair_name(link))
            rows.append(row)
            histories.append(history)
    return pd.DataFrame(rows), pd.concat(histories, ignore_index=True)
