"""Side-by-side scenario comparison (`liaison compare`, 001 Tables 6-7), computed: each scenario's campaign
(campaign.engine.results) reduced to one row, RMS errors averaged over its spacecraft, run counts and the consistency
verdict. report.compare formats it; campaign.studies.output writes it."""

import math

import pandas as pd

from liaison_cli import __version__
from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.analysis.metrics import campaign_error_to_sigma
from liaison_cli.campaign.engine.backends import LOCAL, Backend
from liaison_cli.campaign.engine.results import summarise_campaign
from liaison_cli.provenance import arithmetic_provenance

METRICS = ("rms_position_m", "rms_velocity_m_s", "rms_position_after_day1_m", "rms_velocity_after_day1_m_s")


def compare_rows(scenario, summary: pd.DataFrame) -> dict:
    """Mean over runs that finished, then over spacecraft; run counts kept beside."""
    ok = summary[summary.status == "ok"]
    per_sc = ok.groupby("spacecraft")[list(METRICS)].mean()
    runs = summary.drop_duplicates("run")
    row = {"scenario": scenario.name, "description": scenario.description,
           "spacecraft": len(scenario.spacecraft), "links": len(scenario.links),
           "topology": scenario.topology.kind if scenario.topology else "links",
           "runs": len(runs), "runs_ok": int((runs.status == "ok").sum())}
    for metric in METRICS:
        row[metric] = float(per_sc[metric].mean()) if len(per_sc) else float("nan")
    row.update(consistency_of(ok))
    return row


def consistency_of(ok: pd.DataFrame) -> dict:
    """The worst spacecraft's error/sigma ratio after the settle time (position and velocity, each the campaign
    ratio of analysis.metrics; worst: the farthest from 1 either way), the mean share of epochs with the NEES
    in its 95 % band, and the verdict of every spacecraft (analysis.consistency)."""
    ratios = {"position": [], "velocity": []}
    for _, group in ok.groupby("spacecraft"):
        for kind, unit in (("position", "m"), ("velocity", "m_s")):
            ratios[kind].append(campaign_error_to_sigma(group[f"rms_{kind}_settled_{unit}"],
                                                        group[f"sigma_{kind}_settled_{unit}"]))
    # The worst: farthest from 1 either way (|ln r|), as the verdict is two-sided; NaN wins (max() over NaN would
    # depend on the order).
    worst = {kind: (float("nan") if any(v != v for v in values) else max(values, key=lambda r: abs(math.log(r))
                                                                          if r > 0 else math.inf))
             if values else float("nan") for kind, values in ratios.items()}
    return {"position_error_to_sigma_settled": worst["position"],
            "velocity_error_to_sigma_settled": worst["velocity"],
            "frac_nees_in_band_settled": float(ok.frac_nees_in_band_settled.mean()) if len(ok) else float("nan"),
            **_verdict_of_every_spacecraft(ok)}


def _verdict_of_every_spacecraft(ok: pd.DataFrame) -> dict:
    """consistent_settled when every spacecraft passes analysis.consistency.campaign_verdict; what failed, by name."""
    failed = []
    for name, group in ok.groupby("spacecraft"):
        verdict = campaign_verdict(group)
        if not verdict["consistent_settled"]:
            failed.append(f"{name}: {verdict['consistency_failed']}")
    return {"consistent_settled": not failed and len(ok) > 0, "consistency_failed": " | ".join(failed)}


def compare_study(loaded, runs: int | None, jobs: int, progress: bool,
                  where: Backend = LOCAL) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """(one row per scenario (compare_rows), every run's summary rows with their scenario, {name: scenario YAML})
    of the scenarios `loaded` = [(path, scenario, text)], each run as its own campaign."""
    rows, summaries, texts = [], [], {}
    for _, config, text in loaded:
        _, summary = summarise_campaign(config, runs=runs, jobs=jobs, progress=progress, description=config.name,
                                        where=where)
        rows.append(compare_rows(config, summary))
        summaries.append(summary.assign(scenario=config.name))
        texts[config.name] = text
    return pd.DataFrame(rows), pd.concat(summaries, ignore_index=True), texts


def provenance(texts: dict) -> dict:
    """The metadata of compare.parquet and summary.parquet."""
    return {"package": "liaison", "package_version": __version__, "arithmetic": arithmetic_provenance(),
            "scenarios_yaml": texts}
