"""004's study: each transmitter scenario (scenarios/004/*.yaml) run once per receiver pair (one link each).

Per transmitter and pair:
- 3-sigma histories of the position and velocity error norms from the filter's covariance along the true
  trajectory (LinCov with the filter's own gains, campaign.studies.error_budget): the uncertainty 004 plots, the
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
  first by LinCov and by the EKF, so a ranking that flips with the tuning shows, each with its converged runs;
  the EKF ranks only pairs all of whose runs converged, and lists the others as unrankable (a ranking that
  drops failed runs is not a ranking); the claims' EKF reading does the same (not computable, naming them);
- `check_claims`: every ordering and comparison 004 states (report/data/study004_claims.yaml), checked per grid
  point on the EKF's settled error RMS (primary) and on LinCov's steady 3-sigma (convergence claims: on their
  convergence times), with a flag where the two verdicts differ;
- DOP (004 §4) along the true geometry: sqrt(trace(pinv(H' H))) with H the TDoA path partials with respect
  to the transmitter's position (one pair: 1 / |dTDoA/dr|, in metres of path per metre), its median over
  the epochs that have a measurement, and the share of such epochs.
"""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.analysis.dop import tdoa_dop
from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.campaign.studies.error_budget import error_budget
from liaison_cli.campaign.engine.backends import LOCAL, Backend, session
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.campaign.studies.study_cells import CellStore, grid_points, source_digest
from liaison_cli.campaign.studies.study003 import StudyError
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.scenario.loading import apply_overrides
from liaison_cli.scenario.scenario_model import Scenario


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


def fully_converged(row) -> bool:
    """Every EKF run of the pair converged: only then does its settled error RMS speak for all its runs (a pair
    some of whose runs diverge is not ranked on the survivors: it is unrankable on the EKF's reading)."""
    share = row.get("ekf_converged_share", 1.0)
    return bool(np.isfinite(share) and share >= 1.0)


def converged_text(row) -> str:
    """'6/6': the pair's converged runs out of all its runs ('' when the table does not say)."""
    runs = int(row.get("runs", 0) or 0)
    share = row.get("ekf_converged_share", np.nan)
    return f"{round(share * runs)}/{runs}" if runs and np.isfinite(share) else ""


def rankings(summary: pd.DataFrame, grid_keys: list[str]) -> pd.DataFrame:
    """Per grid point and transmitter, the receiver pairs ordered best first by LinCov's steady 3-sigma
    position and by the EKF's settled error RMS, each pair with its converged runs beside it. The EKF's order
    ranks only the pairs all of whose runs converged (fully_converged); the others are listed after it as
    unrankable, never ranked on their surviving runs. Where a ranking flips with the tuning, the table shows it."""
    rows = []
    group_keys = grid_keys + ["transmitter"]
    for _, part in summary.groupby(group_keys, sort=False, dropna=False):  # a null grid value is a grid point
        keys = [part[k].iloc[0] for k in group_keys]
        by_lincov = list(part.sort_values("steady_3sigma_position_m").pair)
        records = part.to_dict("records")
        rankable = [r for r in records if fully_converged(r) and np.isfinite(r["ekf_error_rms_position_settled_m"])]
        by_ekf = " < ".join(r["pair"] + (f" ({converged_text(r)})" if converged_text(r) else "") for r in
                            sorted(rankable, key=lambda r: r["ekf_error_rms_position_settled_m"]))
        unrankable = [f"{r['pair']} ({converged_text(r)} converged)" for r in records if r not in rankable]
        if unrankable:
            by_ekf = (by_ekf + "; " if by_ekf else "") + "unrankable: " + ", ".join(unrankable)
        rows.append({**dict(zip(group_keys, keys)), "best_first_lincov": " < ".join(by_lincov),
                     "best_first_ekf": by_ekf, "ekf_all_converged": not unrankable})
    return pd.DataFrame(rows)


# --- 004's claims, checked on one metric each ----------------------------------------------------------------
# The claims ship as data beside the report that prints them (report/data/study004_claims.yaml: 004's statement
# in our words, where it comes from, and a metric-free check). Each is evaluated on the EKF's actual error
# after the settle time (primary) and, beside it, on LinCov's steady 3-sigma; convergence claims on the EKF's
# and LinCov's convergence times; the one DOP claim on the geometry alone.

HOLDS, FAILS, NOT_COMPUTABLE, NOT_APPLICABLE = "yes", "no", "not computable", "n/a"
CLAIM_METRICS = {  # quantity -> {reading: summary column}
    "accuracy": {"ekf": "ekf_error_rms_position_settled_m", "lincov": "steady_3sigma_position_m"},
    "convergence": {"ekf": "ekf_converged_days_median", "lincov": "convergence_days_position"},
    "geometry": {"geometry": "median_dop"},
}
# `below` compares 3-sigma bounds: LinCov's steady 3-sigma, and 3 x the EKF's settled error RMS.
BELOW_METRICS = {"ekf": {"position": ("ekf_error_rms_position_settled_m", 3.0),
                         "velocity": ("ekf_error_rms_velocity_settled_m_s", 3.0)},
                 "lincov": {"position": ("steady_3sigma_position_m", 1.0),
                            "velocity": ("steady_3sigma_velocity_m_s", 1.0)}}
READINGS = ("ekf", "lincov", "geometry")
MONTE_CARLO_READING = READINGS[0]  # the Monte Carlo's (a label of the reading, not an estimator name)


def claims_004() -> dict:
    """report/data/study004_claims.yaml: {pairs: alias -> pair name, claims: [...]}."""
    import yaml
    from importlib.resources import files

    return yaml.safe_load(files("liaison_cli.report").joinpath("data/study004_claims.yaml").read_text())


def _listed(value) -> list:
    return list(value) if isinstance(value, (list, tuple)) else [value]


def _metric_name(check: dict, reading: str) -> str:
    if check["kind"] == "below":
        return ", ".join(f"{scale:g} x {column}" if scale != 1 else column
                         for column, scale in BELOW_METRICS[reading].values())
    return CLAIM_METRICS[check["quantity"]][reading]


def _ratio(worse: float, better: float) -> float:
    """worse / better with "never" (inf) allowed: NaN when both are never or both zero."""
    if np.isinf(worse) and np.isinf(better):
        return float("nan")
    if better == 0.0:
        return float("inf") if worse > 0 else float("nan")
    return worse / better


def _verdict(check: dict, values: dict) -> bool | None:
    """One transmitter: does the check hold on `values` (alias -> number, inf = never converges, NaN = not
    computable)? None when it cannot be told."""
    kind = check["kind"]
    if kind == "below":
        position, velocity = values.get("position", np.nan), values.get("velocity", np.nan)
        if not (np.isfinite(position) and np.isfinite(velocity)):
            return None
        return bool(position < check["position_m"] and velocity < check["velocity_m_s"])
    if any(np.isnan(v) for v in values.values()):
        return None
    if kind in ("best_pair", "worst_pair"):
        if len(values) < 2 or all(np.isinf(v) for v in values.values()):
            return None
        mine = values[check["pair"]]
        others = [v for alias, v in values.items() if alias != check["pair"]]
        return bool(mine < min(others)) if kind == "best_pair" else bool(mine > max(others))
    if kind in ("better", "ratio_at_least", "ratio_between"):
        ratios = [_ratio(values[w], values[check["better"]]) for w in _listed(check["worse"])]
        if any(np.isnan(r) for r in ratios):
            return None
        if kind == "better":
            return all(r > 1.0 for r in ratios)
        if kind == "ratio_at_least":
            return all(r >= check["factor"] for r in ratios)
        return all(check["low"] <= r <= check["high"] for r in ratios)
    if kind == "similar":
        first, second = (values[a] for a in check["pairs"])
        ratio = _ratio(max(first, second), min(first, second))
        return None if np.isnan(ratio) else bool(ratio <= check["factor"])
    if kind == "about":
        value = values[check["pair"]]
        return bool(check["value"] / check["factor"] <= value <= check["value"] * check["factor"])
    if kind == "within":
        return all(check["low"] <= values[a] <= check["high"] for a in check["pairs"])
    raise ValueError(f"unknown claim kind {kind!r}")


def _involved(check: dict, aliases: list[str]) -> list[str]:
    """The pairs a check reads: all of them for a ranking, else those it names."""
    kind = check["kind"]
    if kind in ("best_pair", "worst_pair"):
        return aliases
    if kind in ("about", "below"):
        return [check["pair"]]
    if kind == "similar" or kind == "within":
        return list(check["pairs"])
    return [check["better"], *_listed(check["worse"])]


def _transmitter_values(rows: pd.DataFrame, check: dict, reading: str, names: dict) -> tuple[dict, str]:
    """(alias -> value, note) of one transmitter's rows for one reading. A convergence time that never came
    is inf (slower than any time); a missing pair or an accuracy without converged runs is NaN."""
    by_alias = {names.get(pair, pair): row for pair, row in zip(rows.pair, rows.to_dict("records"))}
    wanted = _involved(check, list(dict.fromkeys([*names.values(), *by_alias])))  # a ranking: 004's pairs and more
    missing = [a for a in wanted if a not in by_alias]
    if check["kind"] == "below":
        row = by_alias.get(check["pair"])
        values = {kind: (row[column] * scale if row is not None else np.nan)
                  for kind, (column, scale) in BELOW_METRICS[reading].items()}
        values = {k: float(v) for k, v in values.items()}
    else:
        column = CLAIM_METRICS[check["quantity"]][reading]
        values = {}
        for alias in wanted:
            value = float(by_alias[alias][column]) if alias in by_alias else np.nan
            if check["quantity"] == "convergence" and alias in by_alias and np.isnan(value):
                value = float("inf")  # never converged
            values[alias] = value
    partial = []  # the EKF's reading of a pair some of whose runs did not converge: not judged on the survivors
    if reading == MONTE_CARLO_READING:
        for alias, value in values.items():
            row = by_alias.get(alias) if check["kind"] != "below" else by_alias.get(check["pair"])
            if row is not None and not fully_converged(row) and np.isfinite(value):
                partial.append(f"{alias} converged in {converged_text(row)} runs")
                values[alias] = np.nan
    note = f"no {', '.join(missing)} pair" if missing else ""
    if partial:
        note = "; ".join(filter(None, [note, "unrankable: " + ", ".join(partial)]))
    if not note and any(np.isnan(v) for v in values.values()):
        note = "no converged EKF run" if reading == MONTE_CARLO_READING else "a value is missing"
    return values, note


def _json_values(values: dict) -> dict:
    return {k: ("never" if np.isinf(v) else None if np.isnan(v) else round(float(v), 6)) for k, v in values.items()}


def _evaluate(claim: dict, part: pd.DataFrame, names: dict, reading: str) -> tuple[str, dict, str]:
    """(verdict, {transmitter: {alias: value}}, note) of one claim on one reading over its transmitters: it
    holds when it holds for each; fails when it fails for one; else cannot be told."""
    check = claim["check"]
    verdicts, values, notes = [], {}, []
    for transmitter in check["transmitters"]:
        rows = part[part.transmitter == transmitter]
        if rows.empty:
            verdicts.append(None)
            notes.append(f"{transmitter}: not in the study")
            continue
        numbers, note = _transmitter_values(rows, check, reading, names)
        values[transmitter] = _json_values(numbers)
        verdict = _verdict(check, numbers)
        verdicts.append(verdict)
        if verdict is None:
            notes.append(f"{transmitter}: {note or 'the pairs compared never converged'}")
    if any(v is False for v in verdicts):
        status = FAILS
    elif any(v is None for v in verdicts):
        status = NOT_COMPUTABLE
    else:
        status = HOLDS
    return status, values, "; ".join(notes)


def check_claims(summary: pd.DataFrame, grid_keys: list[str] | None = None, claims: dict | None = None) -> pd.DataFrame:
    """004's claims (claims_004()) checked per grid point on the study's summary: one row per claim and grid
    point with, for each reading (ekf: the EKF's settled error RMS over converged runs, the primary; lincov:
    LinCov's steady 3-sigma; for convergence claims the two convergence times; geometry: the median DOP, for
    geometry claims only), whether the claim holds ("yes", "no", "not computable", "n/a"), the values it was
    judged on (JSON: transmitter -> pair alias -> value, "never" for a convergence that never came), and
    `metrics_disagree` where the EKF and LinCov verdicts are yes and no."""
    import json

    claims = claims or claims_004()
    names = {name: alias for alias, name in claims["pairs"].items()}
    keys = list(grid_keys or [])
    groups = summary.groupby(keys, sort=False, dropna=False) if keys else [((), summary)]  # null is a grid value
    rows = []
    for _, part in groups:
        point = {k: part[k].iloc[0] for k in keys}  # as given (a null stays None)
        for claim in claims["claims"]:
            check = claim["check"]
            row = {**point, "id": claim["id"], "source": claim["source"],
                   "claim": " ".join(claim["claim"].split()), "quantity": check["quantity"], "kind": check["kind"],
                   "check": json.dumps(check, ensure_ascii=False)}
            notes = []
            for reading in READINGS:
                applies = (reading == "geometry") == (check["quantity"] == "geometry")
                if not applies:
                    status, values, metric = NOT_APPLICABLE, {}, ""
                elif check["kind"] == "not_checked":
                    status, values, metric = NOT_COMPUTABLE, {}, ""
                else:
                    status, values, note = _evaluate(claim, part, names, reading)
                    metric = _metric_name(check, reading)
                    if note and status == NOT_COMPUTABLE:
                        notes.append(f"{reading}: {note}")
                row[f"{reading}_metric"] = metric
                row[f"{reading}_holds"] = status
                row[f"{reading}_values"] = json.dumps(values, ensure_ascii=False)
            row["metrics_disagree"] = {row["ekf_holds"], row["lincov_holds"]} == {HOLDS, FAILS}
            row["note"] = " ".join(check["reason"].split()) if check["kind"] == "not_checked" else "; ".join(notes)
            rows.append(row)
    return pd.DataFrame(rows)
