"""Process noise chosen by a stated consistency rule (issue 26 item 2): `liaison tune`.

The rule, for one EKF scenario:
- Ladder: the SNC white acceleration sigma_a (m/s^2, the per-step convention: q = sigma_a^2 dt) takes each value
  of a ladder (default DEFAULT_LADDER_M_S2: 1, 2 and 5 per decade from 1e-10 to 1e-5), the same for every
  estimated spacecraft: the filter key `filter.process_noise_accel_m_s2` is set and every spacecraft's own
  process-noise key (either convention) removed, as is a filter PSD no estimated spacecraft used.
- A scenario whose estimated spacecraft all take an isotropic PSD (`process_noise_psd_m2_s3`, given or by
  default: the templates' and an untuned scenario's) is laddered in its own convention: each rung sigma_a sets
  `filter.process_noise_psd_m2_s3` to q = sigma_a^2 dt (dt the measurement interval), the same Q as the
  per-step sigma_a under the continuous white-acceleration model (estimation.process_noise), so the rule, its
  ladder and its table are the same; the table gives each rung's q (psd_m2_s3) beside it. One whose estimated
  spacecraft all take a PSD per RIC axis in the same proportions (ric_shape) is laddered in that key: each
  rung sets `filter.process_noise_psd_ric_m2_s3` to q times the proportions, q = sigma_a^2 dt the largest
  axis's density (psd_m2_s3 in the table). RIC densities in different proportions are refused before anything
  runs (psd_refusal): one scale does not ladder them.
- Runs: each rung is a Monte Carlo campaign of `runs` runs (default DEFAULT_RUNS = 20) over the scenario's
  whole arc, seeded from the scenario seed and the run index, so every rung sees the same initial errors and
  measurement noise (common random numbers: a difference between rungs is the process noise's, not luck's).
- Statistics, after the scenario's settle time (Scenario.settle_days(): filter.settle_days, default 1 d), over
  the runs that finished: per estimated spacecraft the campaign error RMS / sigma RMS of position and of
  velocity with the 95 % interval of each ratio from the run count (the test's power: the interval narrows as
  1/sqrt(runs)), and the shares of settled epochs whose whole-state NEES, and whose own 6-state NEES, lie in
  their single-run 95 % chi-square bands.
- A rung passes when every run finished 'ok' and every estimated spacecraft passes the one verdict of
  `run`, `compare`, the sweeps and the studies (analysis.consistency.campaign_verdict): the NEES test (whole
  state and own states, at least NEES_REQUIRED_SHARE in band) and the two-sided ratio test (the interval
  reaches [1/1.5, 1.5]: a pessimistic filter fails as an optimistic one does), with a margin: the
  whole-state NEES share at least RULE_NEES_SHARE (90 %, the share the consistency issue asks of every
  shipped scenario). The margin is a preference, not a test at the runs' precision: over 100 runs (the
  shipped table's, and the default) a share's 95 % interval is ±1.5-4 points for the EKF scenarios the rule
  tunes (±3-6 for the batch and 003 ones), over 20 runs ±3-9, so a rung
  at 90.7 % is not shown better than one at 89.9 % (mt_eml2_lunar_range's first 20 runs at 1e-10: 87.4 ± 9.0
  %; its 100: 92.2 ± 2.5 %). What failed is kept per rung
  (`consistency_failed`, or the margin: `rule_failed`) and printed.
- Chosen: the smallest rung that passes ('rule met'). The rungs are run a decade at a time from the lowest.
  When the default ladder's lowest decade has no passing rung and its lowest rung fails for being
  pessimistic (more settled epochs below the NEES band than above it), the ladder first extends below it a
  decade at a time (1, 2, 5 per decade, down to LADDER_FLOOR_M_S2) until a decade has a passing rung or its
  lowest rung is not pessimistic; then, if nothing passed, it climbs, and the decades above the first one
  with a passing rung are not run. When no rung reaches the margin, the smallest rung the verdict passes
  whose share lies within the 95 % interval of the best such share is chosen, and says so ('rule met below
  its margin'): the NEES does not reject it, and a larger rung that beats it by less than the runs resolve
  is not preferred to less noise. When the verdict passes no rung, nothing is chosen ('no rung passes') and
  the shipped value stays: no fallback accepts a filter the NEES rejects. A choice on the ladder's lowest
  rung says only that a smaller value was not tried (the rung passed: less noise is not needed for
  consistency).
- The whole-state share is printed with the half-width of its 95 % interval from the runs' spread
  (1.96 x their standard deviation / sqrt(runs)): the margin's size against the run count's power.
- Batch least squares has no process noise: its scenarios get the shipped row only ('batch: no SNC').
The campaigns are sweeps (campaign.sweep) in a work folder, one per scenario and ladder (plus one for the
shipped settings when they are not a rung): an interrupted `tune` resumes, and a second one reuses every
finished run. The ladder's sweep starts from the scenario set on the lowest rung (ladder_base), so a scenario
whose shipped process noise alone changed keeps its ladder's runs.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from liaison_cli import __version__
from liaison_cli.analysis.consistency import NEES_REQUIRED_SHARE, RATIO_LIMIT, campaign_verdict
from liaison_cli.campaign.engine.backends import LOCAL, Backend
from liaison_cli.campaign.sweep.manifest import sweep_lock
from liaison_cli.campaign.sweep.plan import plan_sweep, scenario_hash
from liaison_cli.campaign.sweep.run import run_sweep
from liaison_cli.errors import LiaisonError
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.scenario.estimation_settings import PROCESS_NOISE_PSD, PROCESS_NOISE_PSD_RIC, PROCESS_NOISE_SIGMA_A
from liaison_cli.scenario.loading import apply_overrides
from liaison_cli.scenario.scenario_model import Scenario
from liaison_cli.storage import resumable_output

SNC_KEY = "filter.process_noise_accel_m_s2"
PSD_KEY = f"filter.{PROCESS_NOISE_PSD}"
PSD_RIC_KEY = f"filter.{PROCESS_NOISE_PSD_RIC}"
RULE_NEES_SHARE = 0.90  # the rule's margin over the verdict's NEES_REQUIRED_SHARE (module docstring)
LADDER_FLOOR_M_S2 = 1e-13  # the default ladder extends no lower than this when its lowest rung is pessimistic
DEFAULT_RUNS = 20
VERDICT_MET = "rule met"
VERDICT_NONE = "no rung passes"
VERDICT_BELOW_MARGIN = "rule met below its margin"
VERDICT_BATCH = "batch: no SNC"


def one_two_five(low: float, high: float) -> tuple[float, ...]:
    """The values 1, 2 and 5 times a power of ten from low to high inclusive (both powers of ten), ascending."""
    first, last = round(np.log10(low)), round(np.log10(high))
    values = [float(f"{m}e{k}") for k in range(first, last + 1) for m in (1, 2, 5)]
    return tuple(v for v in values if v <= high * (1 + 1e-12))


DEFAULT_LADDER_M_S2 = one_two_five(1e-10, 1e-5)


def decades(values) -> list[tuple[float, ...]]:
    """Ascending values grouped by their power of ten, the groups ascending."""
    groups: dict[int, list[float]] = {}
    for value in sorted(values):
        groups.setdefault(int(np.floor(np.log10(value) + 1e-9)), []).append(value)
    return [tuple(groups[k]) for k in sorted(groups)]


class TuningError(LiaisonError):
    """A ladder or scenario the tuning rule cannot take."""


def rule_text(ladder, runs: int) -> str:
    """The rule in one paragraph, with this invocation's ladder and run count (the table's header)."""
    rungs = ", ".join(f"{v:g}" for v in ladder)
    return (f"Rule: sigma_a (m/s^2, every estimated spacecraft alike, per-spacecraft values removed; a scenario "
            f"whose process noise is an isotropic PSD takes q = sigma_a^2 dt, the same Q) takes each "
            f"rung of {{{rungs}}}; {runs} Monte Carlo runs per rung over the scenario's full arc (common random "
            f"numbers), statistics after the "
            f"settle time over the runs that finished. A rung passes when every run finished and every estimated "
            f"spacecraft passes the consistency verdict: the NEES test (at least {NEES_REQUIRED_SHARE:g} of the "
            f"settled epochs' whole-state NEES, and of its own 6-state NEES, in their single-run 95 % chi-square "
            f"bands) and the two-sided ratio test (the 95 % interval of the campaign error RMS / sigma RMS, from "
            f"the {runs} runs, reaches [{1 / RATIO_LIMIT:.2f}, {RATIO_LIMIT:g}] for position and velocity), with a "
            f"margin: the whole-state NEES share at least {RULE_NEES_SHARE:g}. Chosen: the smallest rung that passes "
            f"('{VERDICT_MET}'); rungs run a decade at a time from the lowest, stopping after the first decade with "
            f"a passing rung; when the default ladder's lowest decade has none and its lowest rung is pessimistic, "
            f"the ladder first extends below it a decade at a time (1, 2, 5 per decade, down to "
            f"{LADDER_FLOOR_M_S2:g}) until a decade has a passing rung or its lowest rung is not pessimistic. If no "
            f"rung reaches the margin, the smallest rung the verdict passes whose share is within the 95 % "
            f"interval of the best such share ('{VERDICT_BELOW_MARGIN}'); if the verdict passes none, none "
            f"('{VERDICT_NONE}', the shipped value stays). The share's ± is its 95 % interval from the runs' "
            f"spread (normal approximation): the margin is a preference, not a test at that precision. Batch "
            f"scenarios have no process noise ('{VERDICT_BATCH}').")


def parse_ladder(text: str | None) -> tuple[float, ...]:
    """'1e-9,1e-8' -> (1e-9, 1e-8), sorted ascending; None -> DEFAULT_LADDER_M_S2. Values must be finite, > 0
    and distinct."""
    if text is None:
        return DEFAULT_LADDER_M_S2
    values = []
    for part in text.split(","):
        try:
            value = float(part)
        except ValueError:
            raise TuningError(f"--ladder {text!r}: {part.strip()!r} is not a number; allowed: a comma list of "
                              "accelerations in m/s^2 (e.g. 1e-9,1e-8,1e-7)") from None
        if not np.isfinite(value) or value <= 0.0:
            raise TuningError(f"--ladder {text!r}: {part.strip()!r} is not a positive finite acceleration; allowed: "
                              "values > 0 in m/s^2")
        values.append(value)
    if len(set(values)) != len(values):
        raise TuningError(f"--ladder {text!r}: a value is repeated; allowed: distinct values")
    return tuple(sorted(values))


def takes_psd(scenario: Scenario) -> bool:
    """Whether every estimated spacecraft takes an isotropic PSD (given, or the default): then the ladder sets
    filter.process_noise_psd_m2_s3 (module docstring)."""
    if not scenario.estimator_descriptor().process_noise:  # a batch: no process noise, no ladder
        return False
    estimated = [sc for sc in scenario.spacecraft if sc.role == "estimated"]
    return bool(estimated) and all(scenario.filter.process_noise_of(sc)[0] == PROCESS_NOISE_PSD for sc in estimated)


def ric_shape(scenario: Scenario) -> tuple[float, float, float] | None:
    """The common shape (q_R, q_I, q_C) / max of the RIC densities when every estimated spacecraft takes a PSD
    per RIC axis and all in the same proportions (the ladder then scales them together); else None."""
    if not scenario.estimator_descriptor().process_noise:
        return None
    settings = [scenario.filter.process_noise_of(sc) for sc in scenario.spacecraft if sc.role == "estimated"]
    if not settings or any(key != PROCESS_NOISE_PSD_RIC for key, _ in settings):
        return None
    shapes = {tuple(float(q) / max(value) for q in value) if max(value) > 0 else None for _, value in settings}
    return shapes.pop() if len(shapes) == 1 and None not in shapes else None


def rung_setting(scenario: Scenario) -> tuple[str, callable]:
    """(the key a rung sets, sigma_a m/s^2 -> its value): sigma_a itself; for an isotropic PSD scenario
    q = sigma_a^2 dt; for a RIC PSD scenario the triple of that largest density in the scenario's proportions."""
    interval_s = scenario.measurement.interval_s
    if takes_psd(scenario):
        return PSD_KEY, lambda sigma_a: sigma_a * sigma_a * interval_s
    shape = ric_shape(scenario)
    if shape is not None:
        return PSD_RIC_KEY, lambda sigma_a: tuple(sigma_a * sigma_a * interval_s * part for part in shape)
    return SNC_KEY, lambda sigma_a: sigma_a


def ladder_grid(scenario: Scenario, ladder) -> list[tuple[str, list]]:
    """The sweep grid of the ladder: the rung's key over the rungs (rung_setting), every spacecraft's own value
    and the filter's other process-noise keys (when given) removed."""
    key, value_of = rung_setting(scenario)
    grid = [(key, [value_of(v) for v in ladder])]
    for other in (PROCESS_NOISE_SIGMA_A, PROCESS_NOISE_PSD, PROCESS_NOISE_PSD_RIC):
        if getattr(scenario.filter, other) is not None and f"filter.{other}" != key:
            grid.append((f"filter.{other}", [None]))
    for index, spacecraft in enumerate(scenario.spacecraft):
        for key in (PROCESS_NOISE_SIGMA_A, PROCESS_NOISE_PSD, PROCESS_NOISE_PSD_RIC):
            if getattr(spacecraft, key) is not None:
                grid.append((f"spacecraft.{index}.{key}", [None]))
    return grid


def psd_refusal(label: str, scenario: Scenario) -> str | None:
    """The one-line reason `tune` refuses an EKF scenario whose process noise is a PSD per RIC axis for some
    estimated spacecraft (module docstring), or None."""
    if not scenario.estimator_descriptor().process_noise:
        return None
    flt = scenario.filter
    ric = [sc for sc in scenario.spacecraft if sc.role == "estimated" and flt.process_noise_of(sc)[0] == PROCESS_NOISE_PSD_RIC]
    if not ric or ric_shape(scenario) is not None:
        return None
    return (f"{label}: the process noise of {', '.join(sc.name for sc in ric)} is a PSD per RIC axis "
            f"({PROCESS_NOISE_PSD_RIC}) that is not one shape for every estimated spacecraft, and `liaison tune` "
            f"ladders one scale; allowed: the same {PROCESS_NOISE_PSD_RIC} proportions for every estimated "
            f"spacecraft, filter.{PROCESS_NOISE_PSD} (an isotropic PSD) or filter.{PROCESS_NOISE_SIGMA_A}")


def ladder_base(scenario: Scenario, ladder) -> Scenario:
    """The scenario on the ladder's lowest rung (ladder_grid applied): the base of the ladder's sweep, so the
    sweep (and its finished runs) stays the same when only the shipped process noise changes."""
    return apply_overrides(scenario, {key: values[0] for key, values in ladder_grid(scenario, ladder)},
                           f"{scenario.name} on the ladder")


def shipped_snc(scenario: Scenario) -> dict:
    """{estimated spacecraft: its sigma_a as shipped} (its own value, else the filter's; an isotropic PSD q as the
    sigma_a of the same Q, sqrt(q / dt); a PSD per RIC axis as that of its largest density); None where there is
    neither (the derived default, a batch)."""
    settings = {sc.name: scenario.filter.process_noise_of(sc) for sc in scenario.spacecraft if sc.role == "estimated"}
    if not scenario.estimator_descriptor().process_noise:  # a batch: its key as given, no PSD converted
        return {name: (value if convention == PROCESS_NOISE_SIGMA_A else None)
                for name, (convention, value) in settings.items()}
    interval_s = scenario.measurement.interval_s
    return {name: (value if convention == PROCESS_NOISE_SIGMA_A else
                   float(np.sqrt(value / interval_s)) if convention == PROCESS_NOISE_PSD and value is not None
                   else float(np.sqrt(max(value) / interval_s)) if convention == PROCESS_NOISE_PSD_RIC
                   else None)
            for name, (convention, value) in settings.items()}


def rung_statistics(runs_table: pd.DataFrame) -> pd.DataFrame:
    """Per (point, spacecraft) of a sweep's runs table: runs, runs ok, the campaign error RMS and sigma RMS of
    position (m) and velocity (m/s) after the settle time (sqrt of the mean square over the runs that finished),
    their ratios with their intervals' half-widths, the NEES shares (whole state and own states) and the
    verdict with what failed (analysis.consistency.campaign_verdict)."""
    rows = []
    for (point, name), group in runs_table.groupby(["point", "spacecraft"], sort=False):
        ok = group[group.status == "ok"]
        row = {"point": int(point), "spacecraft": name, "runs": len(group), "runs_ok": len(ok)}
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            errors, sigmas = ok[f"rms_{kind}_settled_{unit}"].dropna(), ok[f"sigma_{kind}_settled_{unit}"].dropna()
            row[f"error_rms_{kind}_{unit}"] = float(np.sqrt(np.mean(errors**2))) if len(errors) else np.nan
            row[f"sigma_rms_{kind}_{unit}"] = float(np.sqrt(np.mean(sigmas**2))) if len(sigmas) else np.nan
        verdict = campaign_verdict(ok)
        for kind in ("position", "velocity"):
            row[f"{kind}_error_to_sigma"] = verdict[f"{kind}_error_to_sigma_settled"]
            row[f"{kind}_error_to_sigma_halfwidth"] = verdict[f"{kind}_error_to_sigma_halfwidth"]
        shares = ok["frac_nees_in_band_settled"].dropna() if "frac_nees_in_band_settled" in ok else pd.Series([])
        row["nees_in_band_halfwidth"] = _share_halfwidth(shares)
        for share in ("in_band", "above_band"):
            row[f"nees_{share}_share"] = verdict[f"frac_nees_{share}_settled"]
            row[f"nees_spacecraft_{share}_share"] = verdict[f"frac_nees_spacecraft_{share}_settled"]
        row["consistent"], row["consistency_failed"] = verdict["consistent_settled"], verdict["consistency_failed"]
        rows.append(row)
    return pd.DataFrame(rows)


def _share_halfwidth(shares: pd.Series) -> float:
    """The 95 % interval's half-width of a mean share over runs: 1.96 x their standard deviation / sqrt(runs)."""
    return float(1.96 * shares.std(ddof=1) / np.sqrt(len(shares))) if len(shares) > 1 else float("nan")


def passes_verdict(stats: pd.DataFrame) -> bool:
    """One rung's rows (one per estimated spacecraft): every run finished and every spacecraft is consistent."""
    finished = bool((stats.runs_ok == stats.runs).all()) and len(stats) > 0
    return finished and bool(stats.consistent.all())


def passes(stats: pd.DataFrame) -> bool:
    """One rung passes the rule: the verdict, with the rule's margin on the whole-state NEES share (module
    docstring)."""
    return passes_verdict(stats) and bool((stats.nees_in_band_share >= RULE_NEES_SHARE).all())


def rule_failure(row: dict) -> str:
    """Why one spacecraft's row fails the rule: the verdict's failure, else the margin's, else ''."""
    if row.get("consistency_failed"):
        return row["consistency_failed"]
    share = row["nees_in_band_share"]
    if not share >= RULE_NEES_SHARE:
        return f"the rule's margin: state NEES in band {100 * share:.1f} % < {100 * RULE_NEES_SHARE:.0f} %"
    return ""


def pessimistic(stats: pd.DataFrame) -> bool:
    """A rung that fails with every run finished and, for some spacecraft, more settled epochs below the
    whole-state NEES band than above it (too much process noise)."""
    if passes(stats) or not bool((stats.runs_ok == stats.runs).all()) or len(stats) == 0:
        return False
    below = 1.0 - stats.nees_in_band_share - stats.nees_above_band_share
    return bool((below > stats.nees_above_band_share).any())


def choose(rungs: list[tuple[float, pd.DataFrame]]) -> tuple[float | None, str]:
    """(chosen sigma_a or None, verdict) from [(rung value, its statistics)] in ascending order: the smallest
    rung that passes; else the smallest verdict-passing rung whose whole-state share is within the 95 %
    interval of the best such share (a rung that beats it by less than the runs resolve is not preferred to
    less noise); else none (module docstring)."""
    for value, stats in rungs:
        if passes(stats):
            return value, VERDICT_MET
    accepted = [(value, float(stats.nees_in_band_share.min()), float(stats.nees_in_band_halfwidth.max()))
                for value, stats in rungs if passes_verdict(stats) and np.isfinite(stats.nees_in_band_share).all()]
    if not accepted:
        return None, VERDICT_NONE
    _, best, half_width = max(accepted, key=lambda entry: entry[1])
    floor = best - (half_width if np.isfinite(half_width) else 0.0)
    return min(value for value, share, _ in accepted if share >= floor), VERDICT_BELOW_MARGIN


@dataclass(frozen=True)
class TuningCase:
    label: str  # the scenario file's stem
    scenario: Scenario
    text: str
    source: str


def _run_point_sweep(case: TuningCase, base: Scenario, grid, runs: int, folder: Path, jobs: int, progress: bool,
                     where: Backend):
    """One sweep of `base` over `grid` (resumable, in `folder`/<plan key>) -> (plan, runs table)."""
    text = case.text if base is case.scenario else yaml.safe_dump(base.model_dump(mode="json", exclude_none=True))
    plan = plan_sweep([(base, text, case.source)], grid, runs, f"tune-{case.label}")
    out_dir = folder / plan.key()
    with sweep_lock(out_dir), resumable_output(out_dir, False, plan.key()) as work_dir:
        result = run_sweep(plan, work_dir, where.name, jobs, where.scheduler, progress,
                           connect_timeout_s=where.connect_timeout_s)
    return plan, result.runs_table


def tune_case(case: TuningCase, ladder, runs: int, work: Path, jobs: int = 1, progress: bool = False,
              where: Backend = LOCAL) -> pd.DataFrame:
    """The table rows of one scenario: per estimated spacecraft, the shipped settings' statistics and the
    rule-chosen rung's (module docstring), with every rung run in the 'ladder' rows."""
    scenario = case.scenario
    estimated = [sc.name for sc in scenario.spacecraft if sc.role == "estimated"]
    folder = work / case.label
    ladder_stats, shipped_stats = [], None
    if scenario.estimator_descriptor().process_noise:
        base = ladder_base(scenario, ladder)

        def run_rungs(values):
            return _rung_sweep(case, base, values, estimated, runs, folder, jobs, progress, where)

        ladder_stats, shipped_stats = _climb(run_rungs, ladder, extend_below=tuple(ladder) == DEFAULT_LADDER_M_S2)
    if shipped_stats is None:
        _, table = _run_point_sweep(case, scenario, [], runs, folder, jobs, progress, where)
        shipped_stats = rung_statistics(table)
        shipped_stats = shipped_stats[shipped_stats.spacecraft.isin(estimated)]
    chosen, verdict = choose(ladder_stats) if ladder_stats else (None, VERDICT_BATCH)
    shipped_passes = passes(shipped_stats)
    shipped = shipped_snc(scenario)
    rows = []
    for setting, value, stats in [("shipped", None, shipped_stats)] + [("rung", v, s) for v, s in ladder_stats]:
        for row in stats.to_dict("records"):
            snc = shipped[row["spacecraft"]] if setting == "shipped" else value
            rows.append({"scenario": case.label, "setting": setting, "spacecraft": row["spacecraft"],
                         "snc_m_s2": snc, "psd_m2_s3": _psd(snc, scenario.measurement.interval_s),
                         "ric_m2_s3": (rung_setting(scenario)[1](snc) if ric_shape(scenario) is not None
                                       and snc is not None else None),
                         "ladder_key": rung_setting(scenario)[0], "settle_days": scenario.settle_days(),
                         "chosen": setting == "rung" and value == chosen, "verdict": verdict,
                         "shipped_passes_rule": shipped_passes,
                         "lowest_rung": setting == "rung" and value == ladder_stats[0][0],
                         "rule_failed": rule_failure(row),
                         **{k: v for k, v in row.items() if k not in ("point", "spacecraft")}})
    return pd.DataFrame(rows)


def _psd(sigma_a, interval_s: float) -> float:
    """The isotropic PSD (m^2/s^3) whose Q equals the per-step sigma_a's under the continuous model."""
    return float("nan") if sigma_a is None else float(sigma_a) ** 2 * interval_s


def _rung_sweep(case: TuningCase, base: Scenario, values, estimated, runs: int, folder: Path, jobs: int,
                progress: bool, where: Backend):
    """One sweep over the rungs `values` -> ([(rung, its estimated spacecraft's statistics)], the statistics of
    the rung that is the shipped scenario itself, or None)."""
    key, value_of = rung_setting(case.scenario)
    rung_of = {_hashable(value_of(v)): v for v in values}
    plan, table = _run_point_sweep(case, base, [(key, [list(k) if isinstance(k, tuple) else k for k in rung_of])],
                                   runs, folder, jobs, progress, where)
    stats = rung_statistics(table)
    shipped_hash, rungs, shipped = scenario_hash(case.scenario), [], None
    for point in plan.points:
        mine = stats[(stats.point == point.index) & stats.spacecraft.isin(estimated)]
        rungs.append((rung_of[_hashable(dict(point.overrides)[key])], mine))
        if point.point_hash == shipped_hash:  # the shipped settings are this rung: no second campaign
            shipped = mine
    return rungs, shipped


def _hashable(value):
    """A rung's value as a dict key: a RIC triple (a list after the sweep plan's round trip) as a tuple."""
    return tuple(float(v) for v in value) if isinstance(value, (list, tuple)) else value


def _climb(run_rungs, ladder, extend_below: bool):
    """The rungs the rule needs, ascending, and the shipped scenario's statistics if it was one of them: the
    ladder's lowest decade; when it has no passing rung, extend_below and its lowest rung is pessimistic, the
    decades below it down to LADDER_FLOOR_M_S2 until one has a passing rung or its lowest rung is not
    pessimistic; when still nothing passes, the ladder's next decades up to the first with a passing rung
    (module docstring)."""
    ladder_decades = decades(ladder)
    evaluated, shipped = run_rungs(ladder_decades[0])
    if any(passes(stats) for _, stats in evaluated):
        return evaluated, shipped
    if extend_below and pessimistic(evaluated[0][1]):
        below = [v for v in one_two_five(LADDER_FLOOR_M_S2, min(ladder)) if v < min(ladder)]
        for decade in reversed(decades(below)):
            rungs, found = run_rungs(decade)
            evaluated, shipped = rungs + evaluated, shipped if found is None else found
            if any(passes(stats) for _, stats in rungs):
                return evaluated, shipped
            if not pessimistic(rungs[0][1]):
                break
    for decade in ladder_decades[1:]:
        rungs, found = run_rungs(decade)
        evaluated, shipped = evaluated + rungs, shipped if found is None else found
        if any(passes(stats) for _, stats in rungs):
            break
    return evaluated, shipped


def tune(cases: list[TuningCase], ladder, runs: int, work: Path, jobs: int = 1, progress: bool = False,
         on_case=None, where: Backend = LOCAL) -> pd.DataFrame:
    """Every case's rows (tune_case), in the order given; `on_case(label)` is called as each one starts. A case
    whose process noise is a PSD per RIC axis is refused before any runs (psd_refusal)."""
    refused = [reason for case in cases if (reason := psd_refusal(case.label, case.scenario)) is not None]
    if refused:
        raise TuningError(refused[0])
    frames = []
    for case in cases:
        if on_case is not None:
            on_case(case.label)
        frames.append(tune_case(case, ladder, runs, Path(work), jobs, progress, where))
    return pd.concat(frames, ignore_index=True)


def provenance(cases: list[TuningCase], ladder, runs: int, command: str) -> dict:
    """The metadata of the tune table's Parquet."""
    return {"package": "liaison", "version": __version__, "arithmetic": arithmetic_provenance(), "command": command,
            "rule": rule_text(ladder, runs),
            "scenarios_yaml": {case.label: case.text for case in cases},
            "seeds": {case.label: case.scenario.monte_carlo.seed for case in cases}}
