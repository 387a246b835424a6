"""003's study: each departure mission's full set and its two reductions, Monte Carlo, per-epoch statistics.

A mission scenario (scenarios/003/*.yaml) is the full set (DSN + LiAISON). The cases (003):
- full: every link;
- dsn_only: the ground links only (both spacecraft tracked from the ground, no crosslink);
- liaison_only: the departing spacecraft is seen through the crosslink only; the EML1 navigation
  satellite keeps its ground tracking.
Statistics per case and spacecraft, over the runs that finished and the epochs after t0:
- 3D RMS of the formal sigma, sqrt(mean(sigma_x^2 + sigma_y^2 + sigma_z^2)): what 003 tabulates;
- 3D RMS of the actual error, and the share of epochs whose error norm is inside its 3-sigma bound.
Histories per epoch: RMS of the error norm over the runs and the mean 3-sigma bound of the norm.
"""

from dataclasses import dataclass

import numpy as np
import pandas as pd

from liaison_cli.campaign.runner import run_campaign
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.errors import LiaisonError
from liaison_cli.scenario.schema import DEPARTURE_ORBIT, Scenario, apply_overrides

CASES = ("full", "dsn_only", "liaison_only")

# 003's stated 3D RMS of the formal uncertainties, full set (its text; the other cases are only plotted).
PAPER_FULL_SET = {
    ("cassini", "navigation"): (26.0, 0.16e-3),
    ("cassini", "departure"): (232.0, 0.36),
    ("mer_a", "departure"): (194.0, 0.63),
    ("msl", "departure"): (84.0, 0.36),
}


class StudyError(LiaisonError):
    """A mission scenario that cannot be split into 003's cases."""


@dataclass(frozen=True)
class CaseResult:
    mission: str
    case: str
    summary: pd.DataFrame  # one row per spacecraft
    history: pd.DataFrame  # one row per spacecraft and epoch


def roles(scenario: Scenario) -> dict:
    """{spacecraft name: 'departure' | 'navigation'}; exactly one departing spacecraft."""
    out = {sc.name: ("departure" if sc.orbit == DEPARTURE_ORBIT else "navigation")
           for sc in scenario.spacecraft if sc.role == "estimated"}
    if list(out.values()).count("departure") != 1:
        raise StudyError(f"{scenario.name}: 003's cases need exactly one spacecraft with orbit: departure")
    return out


def case_scenario(scenario: Scenario, mission: str, case: str) -> Scenario:
    """The mission's full-set scenario reduced to one of 003's cases (links dropped, nothing else changed)."""
    stations = {st.name for st in scenario.ground_stations}
    departing = next(name for name, role in roles(scenario).items() if role == "departure")
    kept = []
    for link in scenario.links:
        ends = {link.receiver, link.transponder}
        on_ground = bool(ends & stations)
        if case == "dsn_only" and not on_ground:
            continue
        if case == "liaison_only" and on_ground and departing in ends:
            continue
        kept.append(link.model_dump(exclude_none=True))
    if case != "full" and len(kept) == len(scenario.links):
        raise StudyError(f"{scenario.name}: case {case} drops no link; the full set needs ground links to both "
                         "spacecraft and a crosslink")
    return apply_overrides(scenario, {"links": kept, "name": f"{mission}_{case}"}, f"{mission} ({case})")


def _statistics(result, mission: str, case: str) -> CaseResult:
    problem = result.problem
    ok = [o for o in result.outcomes if o.status == "ok"]
    if not ok:
        reasons = sorted({o.reason for o in result.outcomes})
        raise StudyError(f"{mission} {case}: no run finished ({'; '.join(reasons)})")
    who = roles(problem.scenario)
    t_days = problem.times_s / SECONDS_PER_DAY
    rows, history = [], []
    for k, name in enumerate(problem.spacecraft):
        stats = {"mission": mission, "case": case, "spacecraft": name, "role": who[name],
                 "runs": len(result.outcomes), "runs_ok": len(ok)}
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            err = np.array([o.norms[f"{kind}_error_{unit}"][:, k] for o in ok])
            bound = np.array([o.norms[f"{kind}_3sigma_{unit}"][:, k] for o in ok])
            late = slice(1, None)
            stats[f"sigma3d_rms_{kind}_{unit}"] = float(np.sqrt(np.mean((bound[:, late] / 3.0) ** 2)))
            stats[f"error3d_rms_{kind}_{unit}"] = float(np.sqrt(np.mean(err[:, late] ** 2)))
            stats[f"inside_3sigma_{kind}"] = float(np.mean(err[:, late] <= bound[:, late]))
            history.append(pd.DataFrame({"mission": mission, "case": case, "spacecraft": name, "role": who[name],
                                         "quantity": kind, "t_days": t_days,
                                         "error_rms": np.sqrt(np.mean(err**2, axis=0)),
                                         "bound_3sigma": np.mean(bound, axis=0)}))
        paper = PAPER_FULL_SET.get((mission, who[name])) if case == "full" else None
        stats["paper_sigma3d_rms_position_m"] = paper[0] if paper else np.nan
        stats["paper_sigma3d_rms_velocity_m_s"] = paper[1] if paper else np.nan
        rows.append(stats)
    return CaseResult(mission, case, pd.DataFrame(rows), pd.concat(history, ignore_index=True))


def run_study(missions: list[tuple[str, Scenario]], runs: int, jobs: int = 2, progress: bool = True):
    """Every mission x case: (summary table, histories table, {(mission, case): scenario})."""
    results, scenarios = [], {}
    for mission, scenario in missions:
        for case in CASES:
            reduced = case_scenario(scenario, mission, case)
            scenarios[(mission, case)] = reduced
            campaign = run_campaign(reduced, runs=runs, jobs=jobs, progress=progress,
                                    description=f"{mission} {case}")
            results.append(_statistics(campaign, mission, case))
    summary = pd.concat([r.summary for r in results], ignore_index=True)
    history = pd.concat([r.history for r in results], ignore_index=True)
    return summary, history, scenarios
