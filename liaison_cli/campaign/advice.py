"""What to change when a campaign's filter is not consistent: the most likely cause among those the tool can tell
apart from a campaign's summary rows and its scenario, and the scenario key that changes it.

Each rule reads what the run text already shows (analysis.consistency.campaign_verdict's side of the NEES band,
the NEES by direction, the runs that diverged) and names one key:

- runs diverged while the scenario declares an unmodelled force (model_error) and the filter carries no
  empirical acceleration: `filter.empirical_acceleration`, naming the force;
- runs diverged or a spacecraft optimistic while `filter.rk4_substeps` fixes fewer substeps than the
  integration tolerance asks for it (scenario.integration_steps): that key, naming the count each needs; such a
  spacecraft is not also told to raise its process noise;
- optimistic, with the common time shift the largest named direction, under the geometric range model:
  `filter.range_model: light_time` (the estimate lags the truth by the signal's flight time);
- optimistic otherwise: more process noise for the spacecraft whose verdict fails on the optimistic side (the
  key in force for each and its value) or `liaison tune`;
- pessimistic: less of it for those whose verdict fails on the pessimistic side only.

A spacecraft's side is read from the tests its verdict fails (each says optimistic or pessimistic): any
optimistic failure makes it optimistic (the more dangerous).

The last three are for estimators that carry process noise (their descriptor says so); a batch gets none.

report.run_text prints each as an `advice:` line under the verdict.
"""

import math
from dataclasses import dataclass

from liaison_cli.analysis.consistency import campaign_verdict, failed_side
from liaison_cli.dynamics.step_choice import SUBSTEP_LADDER

# A direction whose mean NEES component exceeds this share of the whole-state NEES is the cause named.
DOMINANT_SHARE = 0.5


@dataclass(frozen=True)
class Advice:
    cause: str  # diverged_unmodelled_force, integration_step, time_shift, optimistic, pessimistic
    text: str


def campaign_advice(scenario, summary: list[dict], spacecraft, columns, step_choices=None) -> list[Advice]:
    """The advice for a campaign (summary rows of every run, `columns` the consistency columns the verdict
    reads, step_choices the Problem's {spacecraft: dynamics.step_choice.StepChoice}): at most one line per cause,
    in the order of the module docstring."""
    out = []
    diverged = {row.get("run") for row in summary if row.get("status") == "diverged"}
    force = _declared_force(scenario)
    if diverged and force and scenario.filter.empirical_acceleration is None:
        out.append(Advice("diverged_unmodelled_force",
                          f"{len(diverged)} run(s) diverged while the truth feels {force}, which the filter does not "
                          "model: add filter.empirical_acceleration (sigma_m_s2 and time_constant_s matched to "
                          "it; docs/filter.md)"))
    sides = {}  # spacecraft -> optimistic / pessimistic, from the tests its verdict fails
    for name in spacecraft:
        rows = [row for row in summary if row.get("spacecraft") == name and row.get("status") == "ok"]
        if not rows:
            continue
        verdict = campaign_verdict({column: [row.get(column, math.nan) for row in rows] for column in columns})
        side = failed_side(verdict["consistency_failed"]) if not verdict["consistent_settled"] else ""
        if side:
            sides[name] = side
    if not scenario.estimator_descriptor().process_noise:  # a batch: no process noise to name
        return out
    optimistic = [name for name, side in sides.items() if side == "optimistic"]
    pessimistic = [name for name, side in sides.items() if side == "pessimistic"]
    short = _short_steps(step_choices or {})
    if short and (diverged or optimistic):
        out.append(Advice("integration_step", f"the integration step is too long for {_step_text(short)}: "
                          f"filter.rk4_substeps = {next(iter(short.values())).substeps} misses "
                          f"filter.integration_tolerance_m ({scenario.filter.integration_tolerance_m:g} m per "
                          "interval): remove filter.rk4_substeps (each spacecraft's step is then chosen by "
                          "accuracy) or raise it"))
        optimistic = [name for name in optimistic if name not in short]
    if optimistic and _time_shift_dominates(summary, spacecraft[0]) and scenario.filter_range_model() == "geometric":
        out.append(Advice("time_shift", "the estimate lags the truth along the common time shift (the "
                          "signal's flight time the geometric range model leaves out): set "
                          "filter.range_model: light_time"))
    elif optimistic:
        out.append(Advice("optimistic", f"the filter is optimistic (its sigma too small) for "
                          f"{', '.join(optimistic)}: raise {_process_noise(scenario, optimistic)}, or let "
                          "`liaison tune` choose it"))
    if pessimistic:
        out.append(Advice("pessimistic", f"the filter is pessimistic (its sigma too large) for "
                          f"{', '.join(pessimistic)}: lower {_process_noise(scenario, pessimistic)}, or let "
                          "`liaison tune` choose it"))
    return out


def _short_steps(step_choices: dict) -> dict:
    """{spacecraft: its StepChoice} where filter.rk4_substeps fixed a count that misses the tolerance."""
    return {name: choice for name, choice in step_choices.items()
            if choice.source != "auto" and not choice.met}


def _step_text(short: dict) -> str:
    return ", ".join(f"{name} (needs {choice.accurate_substeps})" if choice.accurate_substeps > 0 else
                     f"{name} (misses it even at {SUBSTEP_LADDER[-1]}: a shorter measurement.interval_s)"
                     for name, choice in short.items())


def _time_shift_dominates(summary: list[dict], name: str) -> bool:
    """Whether the mean NEES component along the common time shift is most of the mean whole-state NEES."""
    rows = [row for row in summary if row.get("spacecraft") == name and row.get("status") == "ok"]
    shift = [row.get("time_shift_nees_settled", math.nan) for row in rows]
    total = [row.get("mean_nees_settled", math.nan) for row in rows]
    shift, total = _mean(shift), _mean(total)
    return math.isfinite(shift) and math.isfinite(total) and total > 0 and shift > DOMINANT_SHARE * total


def _mean(values) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return sum(finite) / len(finite) if finite else math.nan


def _process_noise(scenario, names) -> str:
    """The process-noise key in force for the named spacecraft and its value, as the scenario says it (a
    spacecraft's own key, else the filter's, else the default); one phrase per distinct setting."""
    phrases = []
    for spacecraft in (sc for sc in scenario.spacecraft if sc.name in names):
        key, value = scenario.filter.process_noise_of(spacecraft)
        own = getattr(spacecraft, key, None) is not None
        where = f"spacecraft {spacecraft.name}'s {key}" if own else f"filter.{key}"
        shown = ("the default derived for the scenario" if value is None else
                 ", ".join(f"{v:g}" for v in value) if isinstance(value, tuple) else f"{value:g}")
        phrase = f"{where} (now {shown})"
        if phrase not in phrases:
            phrases.append(phrase)
    return " and ".join(phrases)


def _declared_force(scenario) -> str:
    """The unmodelled force model_error declares, in the scenario's words ('' when none)."""
    error = scenario.model_error
    if error.truth_acceleration_sigma_m_s2 > 0.0:
        return (f"model_error.truth_acceleration_sigma_m_s2 = {error.truth_acceleration_sigma_m_s2:g} m/s^2 "
                f"(time constant {error.truth_acceleration_time_constant_s:g} s)")
    if any(a != 0.0 for a in error.truth_acceleration_m_s2):
        return f"model_error.truth_acceleration_m_s2 = {list(error.truth_acceleration_m_s2)} m/s^2"
    return ""
