"""Process noise chosen by a stated consistency rule (issue 26 item 2): `liaison tune`.

The rule, for one EKF scenario:
- Ladder: the SNC white acceleration sigma_a (m/s^2, the per-step convention: q = sigma_a^2 dt) takes each value
  of a ladder (default DEFAULT_LADDER_M_S2, one value per decade from 1e-10 to 1e-5), the same for every
  estimated spacecraft: the filter key `filter.process_noise_accel_m_s2` is set and every spacecraft's own
  process-noise key (either convention) removed, as is a filter PSD no estimated spacecraft used.
- A scenario whose process noise is a PSD (`process_noise_psd_m2_s3`, given or by default, for any estimated
  EKF spacecraft) is refused before anything runs (psd_refusal): the table's values are sigma_a in m/s^2,
  and a ladder of PSD values is not offered.
- Runs: each rung is a Monte Carlo campaign of `runs` runs (default DEFAULT_RUNS = 20) over the scenario's
  whole arc, seeded from the scenario seed and the run index, so every rung sees the same initial errors and
  measurement noise (common random numbers: a difference between rungs is the process noise's, not luck's).
- Statistics, after the scenario's settle time (Scenario.settle_days(): filter.settle_days, default 1 d), over
  the runs that finished: per estimated spacecraft the campaign error RMS / sigma RMS of position and of
  velocity (analysis.metrics.campaign_error_to_sigma), and the mean over runs of the share of epochs whose
  whole-state NEES lies in its two-sided 95 % chi-square band (analysis.metrics.nees_run_band).
- A rung passes the sigma test when every run finished 'ok' and every ratio is at most
  CONSISTENCY_RATIO_LIMIT (1.5: the limit above which `run` marks a spacecraft inconsistent); it passes the
  NEES test when the NEES-in-band share is at least NEES_IN_BAND_MIN (0.8; a consistent filter gives about
  0.95, and the share of one run is correlated in time, so 0.8 leaves room for sampling and still fails a
  filter whose NEES sits outside its band a fifth of the time).
- Chosen: the smallest rung passing both tests ('rule met'). When no rung passes the NEES test, the smallest
  rung passing the sigma test, and the table says so ('sigma test only': the NEES never stays in its band on
  this ladder; process noise alone does not make the filter consistent). When no rung passes the sigma test
  either, nothing is chosen ('no rung passes') and the shipped value stays. A choice on the ladder's lowest
  rung says only that a smaller value was not tried.
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

from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT, campaign_error_to_sigma
from liaison_cli.campaign.backends import LOCAL, Backend
from liaison_cli.campaign.sweep import plan_sweep, run_sweep, scenario_hash, sweep_lock
from liaison_cli.errors import LiaisonError
from liaison_cli.scenario.estimation_settings import PROCESS_NOISE_PSD, PROCESS_NOISE_SIGMA_A
from liaison_cli.scenario.schema import Scenario, apply_overrides
from liaison_cli.storage import resumable_output

SNC_KEY = "filter.process_noise_accel_m_s2"
DEFAULT_LADDER_M_S2 = (1e-10, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5)
DEFAULT_RUNS = 20
NEES_IN_BAND_MIN = 0.8
VERDICT_MET = "rule met"
VERDICT_SIGMA_ONLY = "sigma test only"
VERDICT_NONE = "no rung passes"
VERDICT_BATCH = "batch: no SNC"


class TuningError(LiaisonError):
    """A ladder or scenario the tuning rule cannot take."""


def rule_text(ladder, runs: int) -> str:
    """The rule in one paragraph, with this invocation's ladder and run count (the table's header)."""
    rungs = ", ".join(f"{v:g}" for v in ladder)
    return (f"Rule: sigma_a (m/s^2, every estimated spacecraft alike, per-spacecraft values removed) takes each "
            f"rung of {{{rungs}}}; {runs} Monte Carlo runs per rung over the scenario's full arc (common random "
            f"numbers), statistics after the "
            f"settle time over the runs that finished. A rung passes the sigma test when every run finished and every "
            f"estimated spacecraft's campaign error RMS / sigma RMS is at most {CONSISTENCY_RATIO_LIMIT:g} for position "
            f"and velocity, and the NEES test when the mean share of epochs whose whole-state NEES lies in its 95 % "
            f"chi-square band is at least {NEES_IN_BAND_MIN:g}. Chosen: the smallest rung passing both ('{VERDICT_MET}'); "
            f"if none passes the NEES test, the smallest passing the sigma test ('{VERDICT_SIGMA_ONLY}': the NEES "
            f"never stays in its band on this ladder); if none passes the sigma test, none ('{VERDICT_NONE}', the "
            f"shipped value stays). Batch scenarios have no process noise ('{VERDICT_BATCH}').")


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


def ladder_grid(scenario: Scenario, ladder) -> list[tuple[str, list]]:
    """The sweep grid of the ladder: the filter's sigma_a over the rungs, every spacecraft's own value and the
    filter's PSD (when given) removed."""
    grid = [(SNC_KEY, list(ladder))]
    if scenario.filter.process_noise_psd_m2_s3 is not None:
        grid.append((f"filter.{PROCESS_NOISE_PSD}", [None]))
    for index, spacecraft in enumerate(scenario.spacecraft):
        for key in (PROCESS_NOISE_SIGMA_A, PROCESS_NOISE_PSD):
            if getattr(spacecraft, key) is not None:
                grid.append((f"spacecraft.{index}.{key}", [None]))
    return grid


def psd_refusal(label: str, scenario: Scenario) -> str | None:
    """The one-line reason `tune` refuses an EKF scenario whose process noise is a PSD for some estimated
    spacecraft (module docstring), or None when every estimated spacecraft uses the per-step sigma_a."""
    if not scenario.estimator_descriptor().process_noise:
        return None
    flt = scenario.filter
    psd = [sc for sc in scenario.spacecraft if sc.role == "estimated" and flt.process_noise_of(sc)[0] == PROCESS_NOISE_PSD]
    if not psd:
        return None
    given = flt.process_noise_psd_m2_s3 is not None or any(sc.process_noise_psd_m2_s3 is not None for sc in psd)
    return (f"{label}: the process noise of {', '.join(sc.name for sc in psd)} is a PSD ({PROCESS_NOISE_PSD}"
            f"{'' if given else ', the default when no process-noise key is given'}), and `liaison tune` ladders "
            f"the per-step sigma_a only: give filter.{PROCESS_NOISE_SIGMA_A} instead of any PSD to tune this scenario")


def ladder_base(scenario: Scenario, ladder) -> Scenario:
    """The scenario on the ladder's lowest rung (ladder_grid applied): the base of the ladder's sweep, so the
    sweep (and its finished runs) stays the same when only the shipped process noise changes."""
    return apply_overrides(scenario, {key: values[0] for key, values in ladder_grid(scenario, ladder)},
                           f"{scenario.name} on the ladder")


def shipped_snc(scenario: Scenario) -> dict:
    """{estimated spacecraft: its sigma_a as shipped} (its own value, else the filter's); None where there is no
    sigma_a (a PSD, or a batch scenario without the key)."""
    settings = {sc.name: scenario.filter.process_noise_of(sc) for sc in scenario.spacecraft if sc.role == "estimated"}
    return {name: (value if convention == PROCESS_NOISE_SIGMA_A else None)
            for name, (convention, value) in settings.items()}


def rung_statistics(runs_table: pd.DataFrame) -> pd.DataFrame:
    """Per (point, spacecraft) of a sweep's runs table: runs, runs ok, the campaign error RMS and sigma RMS of
    position (m) and velocity (m/s) after the settle time (sqrt of the mean square over the runs that finished),
    their ratios, and the mean NEES-in-band and above-band shares."""
    rows = []
    for (point, name), group in runs_table.groupby(["point", "spacecraft"], sort=False):
        ok = group[group.status == "ok"]
        row = {"point": int(point), "spacecraft": name, "runs": len(group), "runs_ok": len(ok)}
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            errors, sigmas = ok[f"rms_{kind}_settled_{unit}"].dropna(), ok[f"sigma_{kind}_settled_{unit}"].dropna()
            row[f"error_rms_{kind}_{unit}"] = float(np.sqrt(np.mean(errors**2))) if len(errors) else np.nan
            row[f"sigma_rms_{kind}_{unit}"] = float(np.sqrt(np.mean(sigmas**2))) if len(sigmas) else np.nan
            row[f"{kind}_error_to_sigma"] = campaign_error_to_sigma(errors, sigmas)
        for share in ("in_band", "above_band"):
            values = ok[f"frac_nees_{share}_settled"].dropna()
            row[f"nees_{share}_share"] = float(values.mean()) if len(values) else np.nan
        rows.append(row)
    return pd.DataFrame(rows)


def passes(stats: pd.DataFrame) -> tuple[bool, bool]:
    """(sigma test, NEES test) of one rung's rows (one per estimated spacecraft); see the module docstring."""
    finished = bool((stats.runs_ok == stats.runs).all()) and len(stats) > 0
    ratios = stats[["position_error_to_sigma", "velocity_error_to_sigma"]].to_numpy(dtype=float)
    sigma_test = finished and bool(np.all(ratios <= CONSISTENCY_RATIO_LIMIT))  # NaN fails
    nees = stats.nees_in_band_share.to_numpy(dtype=float)
    nees_test = finished and bool(np.all(nees >= NEES_IN_BAND_MIN))
    return sigma_test, nees_test


def choose(rungs: list[tuple[float, pd.DataFrame]]) -> tuple[float | None, str]:
    """(chosen sigma_a or None, verdict) from [(rung value, its statistics)] in ascending order."""
    tests = [(value, *passes(stats)) for value, stats in rungs]
    for value, sigma_test, nees_test in tests:
        if sigma_test and nees_test:
            return value, VERDICT_MET
    for value, sigma_test, _ in tests:
        if sigma_test:
            return value, VERDICT_SIGMA_ONLY
    return None, VERDICT_NONE


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
    rule-chosen rung's (module docstring), with every rung's statistics in the 'ladder' rows."""
    scenario = case.scenario
    estimated = [sc.name for sc in scenario.spacecraft if sc.role == "estimated"]
    folder = work / case.label
    ladder_stats, shipped_stats = [], None
    if scenario.estimator_descriptor().process_noise:
        plan, table = _run_point_sweep(case, ladder_base(scenario, ladder), [(SNC_KEY, list(ladder))], runs, folder,
                                       jobs, progress, where)
        stats = rung_statistics(table)
        shipped_hash = scenario_hash(scenario)
        for point in plan.points:
            mine = stats[(stats.point == point.index) & stats.spacecraft.isin(estimated)]
            ladder_stats.append((dict(point.overrides)[SNC_KEY], mine))
            if point.point_hash == shipped_hash:  # the shipped settings are this rung: no second campaign
                shipped_stats = mine
    if shipped_stats is None:
        _, table = _run_point_sweep(case, scenario, [], runs, folder, jobs, progress, where)
        shipped_stats = rung_statistics(table)
        shipped_stats = shipped_stats[shipped_stats.spacecraft.isin(estimated)]
    chosen, verdict = choose(ladder_stats) if ladder_stats else (None, VERDICT_BATCH)
    shipped_sigma, shipped_nees = passes(shipped_stats)
    shipped = shipped_snc(scenario)
    rows = []
    for setting, value, stats in [("shipped", None, shipped_stats)] + [("rung", v, s) for v, s in ladder_stats]:
        for row in stats.to_dict("records"):
            snc = shipped[row["spacecraft"]] if setting == "shipped" else value
            rows.append({"scenario": case.label, "setting": setting, "spacecraft": row["spacecraft"],
                         "snc_m_s2": snc, "settle_days": scenario.settle_days(), "chosen": setting == "rung" and value == chosen, "verdict": verdict,
                         "shipped_passes_sigma_test": shipped_sigma, "shipped_passes_nees_test": shipped_nees,
                         "lowest_rung": setting == "rung" and value == min(ladder),
                         **{k: v for k, v in row.items() if k not in ("point", "spacecraft")}})
    return pd.DataFrame(rows)


def tune(cases: list[TuningCase], ladder, runs: int, work: Path, jobs: int = 1, progress: bool = False,
         on_case=None, where: Backend = LOCAL) -> pd.DataFrame:
    """Every case's rows (tune_case), in the order given; `on_case(label)` is called as each one starts. A case
    whose process noise is a PSD is refused before any runs (psd_refusal)."""
    refused = [reason for case in cases if (reason := psd_refusal(case.label, case.scenario)) is not None]
    if refused:
        raise TuningError(refused[0])
    frames = []
    for case in cases:
        if on_case is not None:
            on_case(case.label)
        frames.append(tune_case(case, ladder, runs, Path(work), jobs, progress, where))
    return pd.concat(frames, ignore_index=True)
