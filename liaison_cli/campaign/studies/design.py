"""`liaison design`: which orbit should a spacecraft fly so that the formation navigates itself best?

A design is a base scenario, its candidates and an objective:
- candidates: members of an orbit family at `count` evenly spaced periods in [low, high] days, each at `phases`
  evenly spaced phases along its orbit (0, 1/phases, ...); everything else the spacecraft says (its name, process
  noise, a priori, clock) is kept; times every combination of the values of other factors, any scenario values
  by dotted path (`--vary`: a lunar orbit's altitude or inclination, a link's noise, the measurement interval),
  and every combination of labelled choices, each setting several values at once (`--choices FILE`: whole
  spacecraft, a topology, a receiver pair's link), or those factors alone;
- objective: one spacecraft's position error RMS after the settle time, the statistic a Monte Carlo run reports
  as rms_position_settled_m, the worst or the mean over every estimated spacecraft; or `condition`, the condition number
  of the formation's range information matrix (liaison observability's), smallest first, with the worst position
  error RMS beside it; or, with a threshold (`converge_below_m`), the day the objective's LinCov position error
  falls below it and stays there (ties by the RMS). Whenever both are known, the candidates that no other beats on both (the Pareto front of
  position error and condition number) are marked (pareto_front).

Each candidate is scored by covariance analysis, not Monte Carlo: studies.error_budget's LinCov along the truth
with every error source on (initial error, noise, process noise, biases, model mismatches), so the score is the
error the filter would make, not the σ it would claim. Candidates fan out through the one fan-out
(engine.backends.map_batches: local processes, or a dask cluster), a batch of candidates per task, and a worker
never raises: a candidate that cannot be set up or scored (an orbit the corrector cannot close at that period, a
divergent covariance) keeps its reason in the table. The spacecraft that do not change are propagated once per
worker (scenario.truth.SPACECRAFT_CACHE), not once per candidate. The ranked best `verify` are then run by Monte Carlo with
the consistency verdict, and Spearman's rank correlation between the LinCov score and the Monte Carlo RMS over
them says whether the covariance analysis ranked them as the filter does.
"""

import copy
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from liaison_cli.campaign.studies.design_choices import read_choices
from liaison_cli.campaign.studies.design_store import DesignStore
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.errors import LiaisonError

__all__ = ["DesignStore", "read_choices"]  # kept in their own modules, named here for the design's callers

WORST = "worst"  # the objective over every estimated spacecraft
MEAN = "mean"  # the objective averaged over every estimated spacecraft
CONDITION = "condition"  # the objective on the range information matrix's condition number
# A worker's truths of the spacecraft that do not change between candidates (scenario.truth.SPACECRAFT_CACHE):
# computed once per worker, not once per candidate; bounded.
_FLOWN: dict = {}
FLOWN_MAX_ENTRIES = 64
# Keys that say where a spacecraft flies: replaced by the candidate's family, period and phase.
ORBIT_KEYS = ("orbit", "elements", "period_days", "amplitude_km", "phase", "state_km", "departure", "longitude_deg",
              "orbit_file")


@dataclass(frozen=True)
class Candidate:
    """One candidate: the open spacecraft's family member and phase (family "" when the design varies no orbit
    family), the values of the design's other factors, ((dotted scenario key, value), ...) (`--vary`), and its
    labelled choices, ((factor, label, ((dotted scenario key, value), ...)), ...) (`--choices`)."""

    index: int
    family: str
    period_days: float
    phase: float
    settings: tuple = ()
    choices: tuple = ()


@dataclass(frozen=True)
class Design:
    """The base scenario's mapping (as read), the open spacecraft, the objective (a spacecraft name or WORST)
    and the candidates."""

    base: dict
    open_spacecraft: str
    objective: str
    candidates: tuple
    condition: bool = False  # also each candidate's range_condition_number (about 0.5 s per spacecraft)
    converge_below_m: float | None = None  # rank by the day the objective's error falls below this and stays

    @property
    def rank_columns(self) -> list[str]:
        """The table columns the candidates are ranked by, smallest first (the first decides, the next breaks
        ties)."""
        if self.converge_below_m is not None:
            return ["converge_days", "score_m"]
        return ["range_condition_number"] if self.objective == CONDITION else ["score_m"]


def parse_periods(text: str) -> tuple[float, float, int]:
    """'LOW:HIGH:COUNT' (days, days, whole number) -> (low, high, count); one line on anything else."""
    parts = text.split(":")
    try:
        low, high, count = float(parts[0]), float(parts[1]), int(parts[2])
    except (IndexError, ValueError):
        raise LiaisonError(f"--periods {text!r}: allowed LOW:HIGH:COUNT, e.g. 8:14:7 (days, days, a whole "
                           "number)") from None
    if len(parts) != 3 or not (0 < low <= high) or count < 1 or (count > 1 and low == high):
        raise LiaisonError(f"--periods {text!r}: allowed LOW:HIGH:COUNT with 0 < LOW <= HIGH (LOW < HIGH when "
                           "COUNT > 1) and COUNT at least 1")
    return low, high, count


def candidate_grid(family: str, low: float, high: float, count: int, phases: int, factors=(), choices=()) -> tuple:
    """Every (period, phase) pair, periods evenly spaced in [low, high] and rounded to 1e-6 d (family "": one
    pair, no orbit varied), times every combination of the choices' options ([(factor, [(label, settings)])]) and
    of the factors' values ([(dotted key, values)]): full factorial, the last key varying fastest."""
    import itertools

    if family:
        periods = np.linspace(low, high, count) if count > 1 else np.array([low])
        pairs = [(round(float(p), 6), k / phases) for p in periods for k in range(phases)]
    else:
        pairs = [(math.nan, 0.0)]
    keys = [key for key, _ in factors]
    combinations = [tuple(zip(keys, values)) for values in itertools.product(*[values for _, values in factors])]
    picks = [tuple((factor, label, settings) for factor, (label, settings) in zip([f for f, _ in choices], options))
             for options in itertools.product(*[options for _, options in choices])]
    return tuple(Candidate(i, family, p, phase, settings, picked) for i, ((p, phase), picked, settings)
                 in enumerate(itertools.product(pairs, picks, combinations)))


MAX_CANDIDATES = 100_000  # a design's grid is bounded before anything is built


def make_design(base: dict, open_spacecraft: str | None, objective: str, family: str | None, periods: str | None,
                phases: int, condition: bool = False, factors=(), choices=(),
                converge_below_m: float | None = None) -> Design:
    """The design, checked: the open spacecraft and the objective are the base's, the family is known; a family
    needs an open spacecraft and periods, and a design varies a family, factors ([(dotted key, values)]), choices
    ([(factor, [(label, ((dotted key, value), ...))])], read_choices), or any of them together."""
    from liaison_cli.orbits.families import family_names

    names = spacecraft_of_every_candidate(base, choices)
    allowed = [*names, WORST, MEAN, CONDITION]
    if objective not in allowed:
        raise LiaisonError(f"--objective {objective!r}: allowed: {', '.join(allowed)}")
    if converge_below_m is not None and not (math.isfinite(converge_below_m) and converge_below_m > 0):
        raise LiaisonError(f"--converge-below {converge_below_m!r}: allowed: a position error in metres above 0")
    if converge_below_m is not None and objective == CONDITION:
        raise LiaisonError("--converge-below: not with --objective condition (give a spacecraft, worst or mean)")
    settings = dict(condition=condition or objective == CONDITION, converge_below_m=converge_below_m)
    if family is None and periods is None and open_spacecraft is None:
        if not factors and not choices:
            raise LiaisonError("design: nothing varies; give --family with --open and --periods, and/or --vary "
                               "KEY=V1,V2, and/or --choices FILE")
        _check_factors(base, factors, choices)
        return Design(base, "", objective, candidate_grid("", 0.0, 0.0, 1, 1, factors, choices), **settings)
    if family is None or periods is None or open_spacecraft is None:
        raise LiaisonError("design: --family, --open and --periods go together (the open spacecraft's orbit family "
                           "and its periods); without them, --vary or --choices alone")
    if open_spacecraft not in names:
        raise LiaisonError(f"--open {open_spacecraft!r}: not a spacecraft of the scenario (of every candidate); "
                           f"allowed: {', '.join(names)}")
    if family not in family_names():
        raise LiaisonError(f"--family {family!r}: allowed: {', '.join(family_names())}")
    if phases < 1:
        raise LiaisonError(f"--phases {phases}: allowed: 1 or more")
    low, high, count = parse_periods(periods)
    _check_factors(base, factors, choices, count * phases)
    return Design(base, open_spacecraft, objective, candidate_grid(family, low, high, count, phases, factors, choices),
                  **settings)


def spacecraft_of_every_candidate(base: dict, choices=()) -> list[str]:
    """The spacecraft names every candidate has: the base's, or with choices that set spacecraft (a whole one, or
    its name), the names common to every combination of those choices' options (base order first)."""
    import itertools

    spacecraft = base.get("spacecraft", [])
    naming = [[(factor, label, option) for label, option in options] for factor, options in choices
              if any(str(key).split(".")[0] == "spacecraft" for _, option in options for key, _ in option)]
    common = None
    for combination in itertools.islice(itertools.product(*naming), MAX_CANDIDATES):
        mapping = {"spacecraft": copy.deepcopy(spacecraft)}
        for factor, label, option in combination:
            for key, value in option:
                if str(key).split(".")[0] == "spacecraft":
                    _set_dotted(mapping, key, copy.deepcopy(value), f"choice {factor}.{label}: {key}")
        found = [sc.get("name") for sc in mapping["spacecraft"] if isinstance(sc, dict)]
        common = found if common is None else [name for name in common if name in found]
    return [name for name in (common or []) if isinstance(name, str)]


# Columns of a candidate's row: a --choices factor or a --vary key may not take one of these names.
ROW_COLUMNS = ("rank", "candidate", "family", "period_days", "phase", "score_m", "converge_days", "error",
               "range_condition_number", "pareto", "mc_score_m", "mc_runs_ok", "mc_consistent", "mc_over_lincov")


def _check_factors(base: dict, factors, choices=(), orbit_candidates: int = 1) -> None:
    """Each factor's key and each choice's keys name values of the base scenario (they replace them), no two
    factors share a column, and the grid is bounded."""
    size = orbit_candidates * math.prod(len(values) for _, values in factors) * math.prod(
        len(options) for _, options in choices)
    if size > MAX_CANDIDATES:
        raise LiaisonError(f"design: {size:,} candidates; allowed: at most {MAX_CANDIDATES:,}")
    for key, values in factors:
        _set_dotted(copy.deepcopy(base), key, values[0], f"--vary {key}")
    columns = [key for key, _ in factors] + [factor for factor, _ in choices]
    for column in columns:
        if column in ROW_COLUMNS or column.startswith("visible ") or column.endswith(
                ("_position_m", "_x_m", "_y_m", "_z_m")):
            raise LiaisonError(f"design factor {column!r}: a column of the table already has that name; allowed: any "
                               f"other name (not {', '.join(ROW_COLUMNS)})")
        if columns.count(column) > 1:
            raise LiaisonError(f"design factor {column!r}: given twice (by --vary or --choices); allowed: once")
    for factor, options in choices:
        for label, option in options:
            mapping = copy.deepcopy(base)
            for key, value in option:
                _set_dotted(mapping, key, value, f"choice {factor}.{label}: {key}")


def _set_dotted(mapping: dict, key: str, value, source: str) -> None:
    """mapping[a][b]... = value for key 'a.b...' (list items by index); the parent must exist, the last part may
    be new (an optional key the base leaves out)."""
    node = mapping
    parts = [int(p) if p.isdigit() else p for p in key.split(".")]
    for part in parts[:-1]:
        try:
            node = node[part]
        except (KeyError, IndexError, TypeError):
            raise LiaisonError(f"{source}: the scenario has no '{key.rsplit('.', 1)[0]}'; allowed: a dotted path to "
                               "one of its values (e.g. noise.sigma_m, spacecraft.1.elements.altitude_km)") from None
    if isinstance(node, list) and not (isinstance(parts[-1], int) and parts[-1] < len(node)) or not isinstance(
            node, (dict, list)):
        raise LiaisonError(f"{source}: '{key}' is not a value of the scenario")
    node[parts[-1]] = value


def candidate_mapping(design: Design, candidate: Candidate) -> dict:
    """The base scenario with the open spacecraft on the candidate's orbit, named after the candidate."""
    mapping = copy.deepcopy(design.base)
    mapping["name"] = f"{design.base.get('name', 'design')}-c{candidate.index}"
    for factor, label, settings in candidate.choices:  # first: the family and --vary refine the chosen scenario
        for key, value in settings:
            _set_dotted(mapping, key, copy.deepcopy(value), f"choice {factor}.{label}: {key}")
    opened = [sc for sc in mapping["spacecraft"] if isinstance(sc, dict) and sc.get("name") == design.open_spacecraft]
    if candidate.family and not opened:  # make_design checks every candidate has it: never a silent no-op
        raise LiaisonError(f"the open spacecraft {design.open_spacecraft!r} is not in this candidate")
    for spacecraft in opened if candidate.family else ():
        for key in ORBIT_KEYS:
            spacecraft.pop(key, None)
        spacecraft.update(orbit=candidate.family, period_days=candidate.period_days)
        if candidate.phase:
            spacecraft["phase"] = candidate.phase
    for key, value in candidate.settings:
        _set_dotted(mapping, key, value, f"--vary {key}")
    return mapping


def _objective(design: Design, by_spacecraft: dict) -> float:
    """The objective over the spacecraft's values (RMS or days): the largest, the mean, or the named one's."""
    if design.objective in (WORST, CONDITION):  # ranked by the condition number: the worst error beside it
        return max(by_spacecraft.values())
    if design.objective == MEAN:
        return float(np.mean(list(by_spacecraft.values())))
    return by_spacecraft[design.objective]


def converge_day(times_s, position_variance_m2, below_m: float) -> float:
    """The first epoch (days) from which the position error's 1-sigma stays below `below_m` to the end; inf
    when it ends above."""
    above = np.flatnonzero(~(np.sqrt(position_variance_m2) < below_m))
    if not len(above):
        return float(times_s[0]) / SECONDS_PER_DAY
    if above[-1] == len(times_s) - 1:
        return math.inf
    return float(times_s[above[-1] + 1]) / SECONDS_PER_DAY


def score_candidate(design: Design, candidate: Candidate) -> dict:
    """The candidate's row: its orbit, each estimated spacecraft's LinCov position error RMS and filter σ RMS
    after the settle time (m), in all and per axis of the dynamics model's frame, each link's share of epochs
    measured, the score (the objective's RMS), or `error` with the reason. Never raises."""
    from liaison_cli.campaign.studies.error_budget import error_budget
    from liaison_cli.scenario.loading import validate_scenario
    from liaison_cli.campaign.engine.noise_check import prepare_checked_problem
    from liaison_cli.scenario.truth import SPACECRAFT_CACHE

    row = {"candidate": candidate.index, "family": candidate.family, "period_days": candidate.period_days,
           "phase": candidate.phase, **{factor: label for factor, label, _ in candidate.choices},
           **dict(candidate.settings), "score_m": math.nan, "error": ""}
    try:
        scenario = validate_scenario(candidate_mapping(design, candidate), "design candidate")
        if len(_FLOWN) > FLOWN_MAX_ENTRIES:
            _FLOWN.clear()
        problem = prepare_checked_problem(scenario, {SPACECRAFT_CACHE: _FLOWN})
        budget = error_budget(problem)
        settled = budget.times_s >= scenario.settle_days() * SECONDS_PER_DAY
        rms = {}
        for s, name in enumerate(budget.spacecraft):
            rms[name] = float(np.sqrt(np.mean(budget.total[settled, s, 0])))
            row[f"{name}_rms_position_m"] = rms[name]
            row[f"{name}_sigma_position_m"] = float(np.sqrt(np.mean(budget.filter_variance[settled, s, 0])))
            for a, axis in enumerate("xyz"):  # by direction: the dynamics model's axes
                row[f"{name}_rms_{axis}_m"] = float(np.sqrt(np.mean(budget.total_axes[settled, s, a])))
                row[f"{name}_sigma_{axis}_m"] = float(np.sqrt(np.mean(budget.filter_axes[settled, s, a])))
        row.update(visibility_shares(problem))
        score = _objective(design, rms)
        if not math.isfinite(score):
            raise ValueError("the covariance analysis diverged (a non-finite error)")
        row["score_m"] = score
        if design.converge_below_m is not None:
            row["converge_days"] = _objective(design, {name: converge_day(
                budget.times_s, budget.total[:, s, 0], design.converge_below_m) for s, name in enumerate(
                budget.spacecraft)})
        row["range_condition_number"] = range_condition_number(scenario) if design.condition else math.nan
    except Exception as exc:  # a worker never raises: the reason goes into the table
        row["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
    return row


def visibility_shares(problem) -> dict:
    """{f"visible {link label}": the share of the epochs after t0 at which the link measures anything}."""
    measured = np.isfinite(problem.measurements_true[1:])
    links = np.array([channel.link for channel in problem.channels], dtype=int)
    return {f"visible {label}": float(measured[:, links == link].any(axis=1).mean()) if len(measured) else math.nan
            for link, label in enumerate(problem.link_labels)}


def range_condition_number(scenario) -> float:
    """The condition number of the candidate's range information matrix, computed as `liaison observability`
    computes it (campaign.studies.observability_study: point-mass CRTBP STMs from t0, no a priori, known
    participants and stations as given trajectories, each link over the epochs it measures); NaN where that
    command refuses the scenario (a dated model, a manoeuvre, a second receiver). Large: some direction of the
    formation's state is barely seen. Its STMs (scipy's DOP853) cost about 0.5 s per spacecraft of a 10-day
    formation, eight times the candidate's LinCov: asked for with `liaison design --condition`."""
    from liaison_cli.analysis.observability import analyse
    from liaison_cli.campaign.studies.observability_study import check_supported, known_inputs, scenario_inputs
    from liaison_cli.dynamics.constants import M_PER_LU, TU_S
    from liaison_cli.errors import ScenarioError

    try:
        check_supported(scenario, "design candidate")
    except ScenarioError:
        return math.nan
    names, states0, times_s, links = scenario_inputs(scenario)
    known_states, visible = known_inputs(scenario, times_s)
    result = analyse(states0, times_s / TU_S, links, scenario.noise.resolved_sigma_m() / M_PER_LU, "range", names,
                     known_states=known_states, visible=visible)
    return float(result.condition_number)


def condition_agreement(table: pd.DataFrame) -> float:
    """Spearman's rank correlation between the range information's condition number and the LinCov score over
    every scored candidate (NaN with fewer than three): does the condition number rank as the covariance does?"""
    from scipy.stats import spearmanr

    scored = table[table.score_m.notna() & np.isfinite(table.get("range_condition_number", np.nan))]
    if len(scored) < 3:
        return math.nan
    return float(spearmanr(scored.range_condition_number, scored.score_m).statistic)


def score_batch(design: Design, tasks) -> list[dict]:
    """Worker side of the fan-out: the rows of candidates `tasks` (indices), in order."""
    return [score_candidate(design, design.candidates[i]) for i in tasks]


def score_all(design: Design, jobs: int, where, work=None) -> pd.DataFrame:
    """Every candidate's row, through the one fan-out, ranked (best first; unscored last). With a `work` folder,
    each finished batch of candidates is kept there (DesignStore) and a rerun of the same design scores only the
    batches that are not: an interrupted search resumes, and Ctrl-C ends it with one line saying what is saved."""
    from liaison_cli.campaign.engine.backends import map_batches

    n = len(design.candidates)
    chunk = max(1, min(8, n // (4 * max(jobs, 1))))
    batches = [tuple(range(start, min(start + chunk, n))) for start in range(0, n, chunk)]
    store = DesignStore(work, design, chunk)
    finished = {b: rows for b in range(len(batches)) if (rows := store.read(b)) is not None}
    pending = [b for b in range(len(batches)) if b not in finished]
    with store.saving_on_interrupt(len(batches), finished):
        for b, rows in zip(pending, map_batches(score_batch, {0: design}, ((0, batches[b]) for b in pending), where,
                                                jobs, ordered=True)):
            store.write(b, rows)
            finished[b] = rows
    table = pd.DataFrame([row for b in range(len(batches)) for row in finished[b]])
    if "range_condition_number" not in table:
        table["range_condition_number"] = math.nan
    if design.converge_below_m is not None and "converge_days" not in table:
        table["converge_days"] = math.nan
    table["pareto"] = pareto_front(table)
    table = table.sort_values([*design.rank_columns, "candidate"], na_position="last", kind="stable")
    table.insert(0, "rank", np.arange(1, len(table) + 1))
    table.loc[table[design.rank_columns[0]].isna() | table.score_m.isna(), "rank"] = 0
    return table.reset_index(drop=True)


def pareto_front(table: pd.DataFrame) -> pd.Series:
    """True for the candidates on the Pareto front of the LinCov position error (score_m) and the range condition
    number, both minimised: no other candidate is as good in both and better in one. False where either is not
    finite (no --condition: every row)."""
    score, condition = table.score_m.to_numpy(float), table.range_condition_number.to_numpy(float)
    known = np.isfinite(score) & np.isfinite(condition)
    front = np.zeros(len(table), dtype=bool)
    for i in np.flatnonzero(known):
        others = known & (np.arange(len(table)) != i)
        dominated = others & (score <= score[i]) & (condition <= condition[i]) & (
            (score < score[i]) | (condition < condition[i]))
        front[i] = not dominated.any()
    return pd.Series(front, index=table.index)


def verify(design: Design, table: pd.DataFrame, top: int, runs: int, jobs: int, where) -> pd.DataFrame:
    """The best `top` scored candidates by Monte Carlo (`runs` runs each): the objective's Monte Carlo position
    error RMS after the settle time (RMS over the runs), each estimated spacecraft's (`mc_<name>_rms_position_m`),
    the objective's ratio to the LinCov score, and the verdict of every estimated spacecraft. Adds their columns to a copy of the table."""
    from liaison_cli.analysis.consistency import campaign_verdict
    from liaison_cli.campaign.engine.results import summary_table
    from liaison_cli.campaign.engine.runner import run_campaign
    from liaison_cli.scenario.loading import validate_scenario

    out = table.copy()
    for column, value in (("mc_score_m", math.nan), ("mc_runs_ok", ""), ("mc_consistent", ""),
                          ("mc_over_lincov", math.nan)):
        out[column] = value
    for position in out.index[out["rank"] > 0][:top]:
        candidate = design.candidates[int(out.at[position, "candidate"])]
        mapping = candidate_mapping(design, candidate)
        mapping["monte_carlo"] = {**mapping.get("monte_carlo", {}), "runs": runs}
        summary = summary_table(run_campaign(validate_scenario(mapping, "design candidate"), jobs=jobs,
                                             progress=False, where=where))
        rms, verdicts, ok_counts = {}, [], []
        for name, group in summary.groupby("spacecraft", sort=False):
            ok = group[group.status == "ok"]
            ok_counts.append(f"{len(ok)}/{len(group)}")
            rms[name] = float(np.sqrt(np.mean(ok.rms_position_settled_m**2))) if len(ok) else math.inf
            out.loc[position, f"mc_{name}_rms_position_m"] = rms[name]
            verdicts.append(f"{name} {'yes' if len(ok) and campaign_verdict(ok)['consistent_settled'] else 'no'}")
        score = _objective(design, rms)
        out.at[position, "mc_score_m"] = score
        out.at[position, "mc_over_lincov"] = score / out.at[position, "score_m"]
        out.at[position, "mc_runs_ok"] = ", ".join(ok_counts)
        out.at[position, "mc_consistent"] = ", ".join(verdicts)
    return out


def rank_agreement(table: pd.DataFrame) -> float:
    """Spearman's rank correlation between the LinCov score and the Monte Carlo score over the verified
    candidates (NaN with fewer than three)."""
    from scipy.stats import spearmanr

    verified = table[table.mc_score_m.notna() & np.isfinite(table.mc_score_m)]
    if len(verified) < 3:
        return math.nan
    return float(spearmanr(verified.score_m, verified.mc_score_m).statistic)
