"""What to change when a campaign's filter is not consistent: the most likely cause among those the tool can tell
apart from a campaign's summary rows and its scenario, and the scenario key that changes it.

Each rule reads what the run text already shows (analysis.consistency.campaign_verdict's side of the NEES band,
the NEES by direction, the runs that diverged) and names one key:

- runs diverged while the scenario declares an unmodelled force (model_error) and the filter carries no
  empirical acceleration: `filter.empirical_acceleration`, naming the force;
- optimistic, with the common time shift the largest named direction, under the geometric range model:
  `filter.range_model: light_time` (the estimate lags the truth by the signal's flight time);
- optimistic otherwise: more process noise (the key in force and its value) or `liaison tune`;
- pessimistic: less process noise (the key in force and its value) or `liaison tune`.

The last three are for estimators that carry process noise (their descriptor says so); a batch gets none.

report.run_text prints each as an `advice:` line under the verdict.
"""

import math
from dataclasses import dataclass

from liaison_cli.analysis.consistency import NEES_REQUIRED_SHARE, campaign_verdict

# A direction whose mean NEES component exceeds this share of the whole-state NEES is the cause named.
DOMINANT_SHARE = 0.5


@dataclass(frozen=True)
class Advice:
    cause: str  # diverged_unmodelled_force, time_shift, optimistic, pessimistic
    text: str


def campaign_advice(scenario, summary: list[dict], spacecraft, columns) -> list[Advice]:
    """The advice for a campaign (summary rows of every run, `columns` the consistency columns the verdict
    reads): at most one line per cause, in the order of the module docstring."""
    out = []
    diverged = {row.get("run") for row in summary if row.get("status") == "diverged"}
    force = _declared_force(scenario)
    if diverged and force and scenario.filter.empirical_acceleration is None:
        out.append(Advice("diverged_unmodelled_force",
                          f"{len(diverged)} run(s) diverged while the truth feels {force}, which the filter does not "
                          "model: add filter.empirical_acceleration (sigma_m_s2 and time_constant_s matched to "
                          "it; docs/filter.md)"))
    sides = set()
    for name in spacecraft:
        rows = [row for row in summary if row.get("spacecraft") == name and row.get("status") == "ok"]
        if not rows:
            continue
        verdict = campaign_verdict({column: [row.get(column, math.nan) for row in rows] for column in columns})
        if verdict["consistent_settled"]:
            continue
        sides.add(_side(verdict))
    if not scenario.estimator_descriptor().process_noise:  # a batch: no process noise to name
        return out
    if "optimistic" in sides:
        if _time_shift_dominates(summary, spacecraft[0]) and scenario.filter_range_model() == "geometric":
            out.append(Advice("time_shift", "the estimate lags the truth along the common time shift (the "
                              "signal's flight time the geometric range model leaves out): set "
                              "filter.range_model: light_time"))
        else:
            out.append(Advice("optimistic", f"the filter is optimistic (its sigma too small): raise "
                              f"{_process_noise(scenario)}, or let `liaison tune` choose it"))
    if "pessimistic" in sides:
        out.append(Advice("pessimistic", f"the filter is pessimistic (its sigma too large): lower "
                          f"{_process_noise(scenario)}, or let `liaison tune` choose it"))
    return out


def _side(verdict: dict) -> str:
    """optimistic or pessimistic: the NEES band's side with more of the settled epochs when the NEES test
    failed, else the side of the error / sigma ratio."""
    inside = verdict.get("frac_nees_in_band_settled", math.nan)
    above = verdict.get("frac_nees_above_band_settled", math.nan)
    if math.isfinite(inside) and inside < NEES_REQUIRED_SHARE and math.isfinite(above):
        return "optimistic" if above >= 1.0 - inside - above else "pessimistic"
    ratio = verdict.get("position_error_to_sigma_settled", math.nan)
    return "optimistic" if math.isfinite(ratio) and ratio > 1.0 else "pessimistic"


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


def _process_noise(scenario) -> str:
    """The process-noise key in force for the first estimated spacecraft and its value, as the scenario says
    it (a spacecraft's own key, else the filter's, else the default)."""
    spacecraft = next(sc for sc in scenario.spacecraft if sc.role == "estimated")
    key, value = scenario.filter.process_noise_of(spacecraft)
    own = getattr(spacecraft, key, None) is not None
    where = f"spacecraft {spacecraft.name}'s {key}" if own else f"filter.{key}"
    shown = ", ".join(f"{v:g}" for v in value) if isinstance(value, tuple) else f"{value:g}"
    return f"{where} (now {shown})"


def _declared_force(scenario) -> str:
    """The unmodelled force model_error declares, in the scenario's words ('' when none)."""
    error = scenario.model_error
    if error.truth_acceleration_sigma_m_s2 > 0.0:
        return (f"model_error.truth_acceleration_sigma_m_s2 = {error.truth_acceleration_sigma_m_s2:g} m/s^2 "
                f"(time constant {error.truth_acceleration_time_constant_s:g} s)")
    if any(a != 0.0 for a in error.truth_acceleration_m_s2):
        return f"model_error.truth_acceleration_m_s2 = {list(error.truth_acceleration_m_s2)} m/s^2"
    return ""
