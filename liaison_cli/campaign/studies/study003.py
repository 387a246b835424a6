"""003's study: each departure mission's full set and its two reductions, Monte Carlo, per-epoch statistics.

A mission scenario (scenarios/003/*.yaml) is the full set (DSN + LiAISON). The cases (003):
- full: every link;
- dsn_only: the ground links only (both spacecraft tracked from the ground, no crosslink);
- liaison_only: the departing spacecraft is seen through the crosslink only; the EML1 navigation
  satellite keeps its ground tracking.
Statistics per case and spacecraft, over the runs that finished, over the epochs after t0 and over those
after the scenario's filter.settle_days (the first hours hold most of a departure's 9-day mean square):
- 3D RMS of the formal sigma, sqrt(mean(sigma_x^2 + sigma_y^2 + sigma_z^2)): one reading of 003's
  "3D RMS"; the other reading, per axis, is that divided by sqrt(3) (both are in the table);
- 3D RMS of the actual error, its ratio to the sigma's (consistency: analysis.metrics' limit), the share
  of epochs whose error norm is inside its 3-sigma bound, and the share whose NEES lies in its 95 % band.
Histories per epoch: RMS of the error norm over the runs and the mean 3-sigma bound of the norm.
`tuning(scenario)` states the filter settings a table depends on; `run_study(..., grid=...)` repeats the
study over a grid of settings (e.g. filter.underweighting=0,0.2) so a ranking's sensitivity is shown.
`DSN_NOISE_READINGS`: 003's Table 2 gives its DSN links 10 m / 0.5 mm/s, its text 1 m / 0.1 mm/s.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.campaign.engine.backends import LOCAL, Backend, session
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.campaign.studies.study_cells import CellStore, grid_points, source_digest
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.errors import LiaisonError
from liaison_cli.scenario.estimation_settings import PROCESS_NOISE_PSD, PROCESS_NOISE_PSD_RIC, PROCESS_NOISE_UNITS
from liaison_cli.scenario.loading import apply_overrides
from liaison_cli.scenario.participants import DEPARTURE_ORBIT
from liaison_cli.scenario.scenario_model import Scenario

CASES = ("full", "dsn_only", "liaison_only")
# 003's two statements of its DSN noise (range m, range-rate m/s): the scenario files use Table 2's.
DSN_NOISE_READINGS = {"table2": (10.0, 0.5e-3), "text": (1.0, 0.1e-3)}

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


def with_dsn_noise(scenario: Scenario, reading: str) -> Scenario:
    """Every ground link's noise set to one of 003's two readings (DSN_NOISE_READINGS)."""
    range_m, rate_m_s = DSN_NOISE_READINGS[reading]
    stations = {st.name for st in scenario.ground_stations}
    links = []
    for link in scenario.links:
        data = link.model_dump(exclude_none=True)
        if {link.receiver, link.transponder} & stations:
            data["noise"] = {**data.get("noise", {}), "sigma_m": range_m, "range_rate_sigma_m_s": rate_m_s}
        links.append(data)
    return apply_overrides(scenario, {"links": links}, f"{scenario.name} (DSN noise: 003 {reading})")


def _number_text(value) -> str:
    """A density or sigma_a as %g, or a RIC triple as [q_R, q_I, q_C]."""
    if value is None:
        return "the derived default"
    return f"[{', '.join(f'{q:g}' for q in value)}]" if isinstance(value, tuple) else f"{value:g}"


def process_noise_text(scenario: Scenario) -> str:
    """The process noise in force, with its convention: 'SNC sigma_a 2e-08 m/s^2 (per-step convention, <model>)'
    or 'SNC PSD 1e-12 m^2/s^3 (...)'; where estimated spacecraft differ, each value names its spacecraft."""
    flt = scenario.filter
    by_convention: dict[str, dict[float, list[str]]] = {}
    for sc in scenario.spacecraft:
        if sc.role == "estimated":
            convention, value = flt.process_noise_of(sc)
            by_convention.setdefault(convention, {}).setdefault(value, []).append(sc.name)
    parts = []
    for convention, values in by_convention.items():
        unit = PROCESS_NOISE_UNITS[convention]
        text = ", ".join(f"{_number_text(value)} {unit}" + (f" for {', '.join(names)}" if len(values) > 1 or len(
            by_convention) > 1 else "") for value, names in values.items())
        parts.append(f"PSD {text} (isotropic white acceleration, independent of the interval)"
                     if convention == PROCESS_NOISE_PSD else
                     f"PSD per radial / in-track / cross-track axis {text}" if convention == PROCESS_NOISE_PSD_RIC else
                     f"sigma_a {text} (per-step convention, {flt.process_noise_model})")
    return "SNC " + "; ".join(parts)


def tuning(scenario: Scenario) -> str:
    """The filter settings a study's numbers depend on, in one line for its table header."""
    flt = scenario.filter
    gate = f"{flt.residual_gate_sigma:g} sigma" if flt.residual_gate_sigma else "off"
    apriori = ", ".join(
        f"{sc.name} {sc.apriori_sigma_position_m or flt.initial_sigma_position_m:g} m / "
        f"{sc.apriori_sigma_velocity_m_s or flt.initial_sigma_velocity_m_s:g} m/s"
        for sc in scenario.spacecraft if sc.role == "estimated")
    return (f"{process_noise_text(scenario)}, underweighting beta {flt.underweighting:g}, "
            f"a priori (1 sigma per axis) {apriori}, residual gate {gate}, settle {scenario.settle_days():g} d")


def _statistics(result, mission: str, case: str) -> CaseResult:
    problem = result.problem
    ok = [o for o in result.outcomes if o.status == "ok"]
    if not ok:
        reasons = sorted({o.reason for o in result.outcomes})
        raise StudyError(f"{mission} {case}: no run finished ({'; '.join(reasons)})")
    who = roles(problem.scenario)
    t_days = problem.times_s / SECONDS_PER_DAY
    settled = problem.times_s >= problem.scenario.settle_days() * SECONDS_PER_DAY
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
            stats[f"sigma3d_rms_{kind}_{unit}_settled"] = float(np.sqrt(np.mean((bound[:, settled] / 3.0) ** 2)))
            stats[f"error3d_rms_{kind}_{unit}_settled"] = float(np.sqrt(np.mean(err[:, settled] ** 2)))
            stats[f"error_to_sigma_{kind}"] = (stats[f"error3d_rms_{kind}_{unit}"]
                                               / stats[f"sigma3d_rms_{kind}_{unit}"])
            stats[f"error_to_sigma_{kind}_settled"] = (stats[f"error3d_rms_{kind}_{unit}_settled"]
                                                       / stats[f"sigma3d_rms_{kind}_{unit}_settled"])
            history.append(pd.DataFrame({"mission": mission, "case": case, "spacecraft": name, "role": who[name],
                                         "quantity": kind, "t_days": t_days,
                                         "error_rms": np.sqrt(np.mean(err**2, axis=0)),
                                         "bound_3sigma": np.mean(bound, axis=0)}))
        stats["frac_nees_in_band_settled"] = float(np.mean([row["frac_nees_in_band_settled"] for o in ok
                                                            for row in o.summary if row["spacecraft"] == name]))
        verdict = campaign_verdict(pd.DataFrame([row for o in ok for row in o.summary if row["spacecraft"] == name]))
        stats["consistent_settled"], stats["consistency_failed"] = (verdict["consistent_settled"],
                                                                    verdict["consistency_failed"])
        paper = PAPER_FULL_SET.get((mission, who[name])) if case == "full" else None
        stats["paper_sigma3d_rms_position_m"] = paper[0] if paper else np.nan
        stats["paper_sigma3d_rms_velocity_m_s"] = paper[1] if paper else np.nan
        rows.append(stats)
    return CaseResult(mission, case, pd.DataFrame(rows), pd.concat(history, ignore_index=True))


def _case_tables(scenario: Scenario, mission: str, case: str, runs: int, jobs: int, progress: bool,
                 truth_cache: dict, where: Backend) -> dict:
    campaign = run_campaign(scenario, runs=runs, jobs=jobs, progress=progress, description=f"{mission} {case}",
                            truth_cache=truth_cache, where=where)
    result = _statistics(campaign, mission, case)
    return {"summary": result.summary, "history": result.history}


def run_study(missions: list[tuple[str, Scenario]], runs: int, jobs: int = 2, progress: bool = True,
              grid: list[tuple[str, list]] | None = None, dsn_noise: str | None = None, where: Backend = LOCAL,
              work: Path | None = None):
    """Every grid point x mission x case: (summary table, histories table, {(point, mission, case): scenario}).
    A grid point is a dict of overrides (apply_overrides keys) applied to every mission's scenario; with no
    grid, one point without overrides. Grid keys become columns of both tables. `work`: the folder of finished
    cells (study_cells): an interrupted study started again computes only the cells missing there."""
    points = grid_points(grid)
    store = CellStore(work, "study003", source_digest(__file__))
    results, scenarios = [], {}
    cells = len(points) * len(missions) * len(CASES)
    with store.saving_on_interrupt(cells), session(where, jobs):  # session: one dask cluster for every cell
        for index, point in enumerate(points):
            for mission, scenario in missions:
                base = apply_overrides(scenario, point, f"{mission} {point}") if point else scenario
                if dsn_noise is not None:  # otherwise the file's own ground-link noise
                    base = with_dsn_noise(base, dsn_noise)
                shared: dict = {}  # the cases differ only in links: their trajectories are flown once
                for case in CASES:
                    reduced = case_scenario(base, mission, case)
                    scenarios[(index, mission, case)] = reduced
                    tables = store.cell(f"p{index}_{mission}_{case}", reduced, runs, lambda: _case_tables(
                        reduced, mission, case, runs, jobs, progress, shared, where))
                    for part in tables.values():
                        for key, value in point.items():
                            part[key] = value
                    results.append(tables)
    summary = pd.concat([r["summary"] for r in results], ignore_index=True)
    history = pd.concat([r["history"] for r in results], ignore_index=True)
    return summary, history, scenarios
