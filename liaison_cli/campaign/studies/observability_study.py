"""Observability of a scenario (001 §5, 000 Fig. 16-17), computed: the information matrix of its links
along the estimated spacecraft's ballistic arcs for range and for range-rate links (SVD, condition
number, unobservability index, per-epoch effectiveness), range-rate against range information (gamma),
and the Taylor-series STM against the integrated one. report.observability_report formats and draws it;
`liaison observability` writes it (campaign.studies.output)."""

from dataclasses import dataclass

import numpy as np
import pandas as pd

from liaison_cli.analysis.observability import analyse, stm_from_t0, taylor_stm_errors
from liaison_cli.dynamics.constants import LU_KM, M_PER_LU, M_S_PER_VU, MU, SECONDS_PER_DAY, TU_S
from liaison_cli.errors import ScenarioError
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.scenario.reference_states import phased_state_lu
from liaison_cli.dynamics.registry import DYNAMICS
from liaison_cli.scenario.truth import dynamics_model, link_visibility, measurement_times_s, participant_trajectories

TAYLOR_STEPS_S = (10, 60, 100, 600)


def check_supported(scenario, source: str) -> None:
    """What the analysis cannot honour is refused in one line, not analysed as something else: it maps
    partials with the CRTBP's STM along ballistic arcs (a dated scenario would silently become the CRTBP, a
    manoeuvre would be left out) and takes two-end links (range and range-rate between a receiver and a
    transponder)."""
    if not scenario.dynamics_descriptor().observability:
        allowed = ", ".join(d.name for d in DYNAMICS.values() if d.observability)
        raise ScenarioError(f"{source}: key 'dynamics' = {scenario.dynamics!r}: observability supports "
                            f"{allowed.upper()} scenarios only (it maps partials with that model's STM); allowed: "
                            f"dynamics: {allowed}")
    for i, sc in enumerate(scenario.spacecraft):
        if sc.orbit_file is not None:
            raise ScenarioError(f"{source}: key 'spacecraft[{i}].orbit' = {{{sc.orbit_file.kind}: ...}}: observability "
                                "propagates each spacecraft from its initial state with the CRTBP's STM; allowed: "
                                "catalog, family or Keplerian orbits")
        if sc.manoeuvre is not None:
            raise ScenarioError(f"{source}: key 'spacecraft[{i}].manoeuvre': observability maps the information "
                                "along ballistic arcs; allowed: spacecraft without a manoeuvre")
    for i, link in enumerate(scenario.links):
        if link.second_receiver is not None:
            raise ScenarioError(f"{source}: key 'links[{i}].second_receiver' = {link.second_receiver!r}: "
                                "observability analyses two-end links (range, range-rate); allowed: links "
                                "without a second receiver")


def scenario_inputs(scenario):
    """names and states0 (n_sc, 6) of the estimated spacecraft, times_s (m,), links as (receiver,
    transponder) indices: i < n_sc an estimated spacecraft, n_sc + j the j-th known participant (known
    spacecraft, then ground stations; see known_inputs)."""
    names = scenario.spacecraft_names()
    states0 = np.array([phased_state_lu(sc) for sc in scenario.spacecraft if sc.role == "estimated"])
    times_s = measurement_times_s(scenario)
    index = {name: i for i, name in enumerate([*names, *_known_names(scenario)])}
    links = [(index[link.receiver], index[link.transponder]) for link in scenario.links]
    return names, states0, times_s, links


def _known_names(scenario) -> list[str]:
    return [sc.name for sc in scenario.spacecraft if sc.role == "known"] + [st.name for st in scenario.ground_stations]


def known_inputs(scenario, times_s):
    """(known_states (m, k, 6) in scenario_inputs' order, visible (n_links, m)): the known participants'
    trajectories and the epochs each link measures (elevation masks, occultation, station_priority)."""
    model = dynamics_model(scenario)
    trajectories = participant_trajectories(scenario, model, times_s)
    known = _known_names(scenario)
    known_states = np.stack([trajectories[name].states for name in known], axis=1) if known else None
    return known_states, np.array(link_visibility(scenario, model, times_s, trajectories))


@dataclass(frozen=True, eq=False)
class ObservabilityStudy:
    """summary: the figures `liaison observability` prints and observability.json holds; effectiveness,
    singular, taylor (None without it): the tables; results: {observable: analysis.observability result};
    names, times_s (m,), moon_km (m, n_sc): what the effectiveness figure draws."""

    summary: dict
    effectiveness: pd.DataFrame
    singular: pd.DataFrame
    taylor: pd.DataFrame | None
    results: dict
    names: list
    times_s: np.ndarray
    moon_km: np.ndarray


def observability_study(scenario, range_rate_sigma_m_s: float = 1e-3, taylor: bool = True) -> ObservabilityStudy:
    """The analysis for range and range-rate links, with the gamma merit and (taylor) the STM comparison."""
    names, states0, times_s, links = scenario_inputs(scenario)
    known_states, visible = known_inputs(scenario, times_s)
    times_tu = times_s / TU_S
    sigmas = {"range": scenario.noise.resolved_sigma_m() / M_PER_LU, "range_rate": range_rate_sigma_m_s / M_S_PER_VU}
    propagated = stm_from_t0(states0, times_tu)  # shared by both observables
    moon_km = np.linalg.norm(propagated[0][:, :, :3] - np.array([1.0 - MU, 0.0, 0.0]), axis=2) * LU_KM
    summary = {"scenario": scenario.name, "epochs": len(times_s),
               "links": [[link.receiver, link.transponder] for link in scenario.links],
               "sigma_range_m": scenario.noise.resolved_sigma_m(), "sigma_range_rate_m_s": range_rate_sigma_m_s,
               "units": "state in LU and LU/TU; weights 1/sigma^2 in the same units", "observables": {}}
    frames, singular_rows, results = [], [], {}
    for observable, sigma in sigmas.items():
        result = analyse(states0, times_tu, links, sigma, observable, names, propagated=propagated,
                         known_states=known_states, visible=visible)
        results[observable] = result
        summary["observables"][observable] = _observable_summary(result)
        singular_rows += _singular_rows(observable, result)
        frames += [pd.DataFrame({
            "observable": observable, "t_s": times_s, "spacecraft": name,
            "position_effectiveness": result.effectiveness_position[:, s],
            "velocity_effectiveness": result.effectiveness_velocity[:, s],
            "moon_distance_km": moon_km[:, s],
        }) for s, name in enumerate(names)]
    gamma_frames, summary["gamma_range_rate_over_range"] = _range_rate_merit(results, names, times_s, moon_km)
    taylor_table = None
    if taylor:
        summary["taylor_stm"] = _taylor_rows(states0, names, times_s)
        taylor_table = pd.DataFrame(summary["taylor_stm"])
    return ObservabilityStudy(summary, pd.concat(frames + gamma_frames, ignore_index=True),
                              pd.DataFrame(singular_rows), taylor_table, results, names, times_s, moon_km)


def _observable_summary(result) -> dict:
    return {
        "condition_number": result.condition_number,
        "unobservability_index": result.unobservability_index,
        "gramian_condition_number": result.gramian_condition_number,
        "most_observable": result.direction(0),
        "least_observable": result.direction(-1),
    }


def _singular_rows(observable: str, result) -> list[dict]:
    return [{"observable": observable, "index": j, "singular_value": value,
             **{label: result.right_vectors[i, j] for i, label in enumerate(result.labels)}}
            for j, value in enumerate(result.singular_values)]


def _range_rate_merit(results, names, times_s, moon_km):
    """Range vs range-rate figure of merit (001 §5.4): the ratio of the per-epoch information each link type
    gives a spacecraft's position (velocity), weights 1/sigma^2 included. gamma >= 1: range-rate is a
    feasible alternative to range at that epoch. Returns (effectiveness frames, per-spacecraft rows)."""
    rng, rate = results["range"], results["range_rate"]
    with np.errstate(divide="ignore", invalid="ignore"):
        gamma_pos = (rate.effectiveness_position / rng.effectiveness_position) ** 2
        gamma_vel = (rate.effectiveness_velocity / rng.effectiveness_velocity) ** 2
    frames, rows = [], []
    for s, name in enumerate(names):
        frames.append(pd.DataFrame({"observable": "gamma_range_rate_over_range", "t_s": times_s, "spacecraft": name,
                                    "position_effectiveness": gamma_pos[:, s], "velocity_effectiveness": gamma_vel[:, s],
                                    "moon_distance_km": moon_km[:, s]}))
        valid = np.isfinite(gamma_pos[:, s])
        rows.append({"spacecraft": name,
                     "gamma_position_median": float(np.median(gamma_pos[valid, s])),
                     "share_epochs_gamma_position_ge_1": float(np.mean(gamma_pos[valid, s] >= 1.0)),
                     "gamma_velocity_median": float(np.median(gamma_vel[valid, s])),
                     "share_epochs_gamma_velocity_ge_1": float(np.mean(gamma_vel[valid, s] >= 1.0))})
    return frames, rows


def _taylor_rows(states0, names, times_s) -> list[dict]:
    """The Taylor-series STM against the integrated one, per spacecraft and step, over up to 7 days."""
    duration_tu = min(7.0 * SECONDS_PER_DAY, times_s[-1]) / TU_S
    rows = []
    for s, name in enumerate(names):
        for step, (rms, std) in taylor_stm_errors(states0[s], duration_tu, TAYLOR_STEPS_S).items():
            rows.append({"spacecraft": name, "step_s": step, "relative_error_rms": rms, "relative_error_std": std})
    return rows


def provenance(study: ObservabilityStudy, scenario_text: str) -> dict:
    """The metadata of the study's Parquet tables."""
    return {"package": "liaison", "arithmetic": arithmetic_provenance(), "scenario_yaml": scenario_text,
            "summary": study.summary}


def study_tables(study: ObservabilityStudy) -> dict:
    """{stem: table} of the Parquet files: effectiveness, singular values and (when computed) the Taylor STM."""
    return {"effectiveness": study.effectiveness, "singular": study.singular,
            **({"taylor_stm": study.taylor} if study.taylor is not None else {})}
