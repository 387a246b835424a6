"""Result tables of a campaign (Parquet, written atomically by liaison_cli.storage) with provenance."""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli import __version__
from liaison_cli.analysis.metrics import nees_band
from liaison_cli.campaign.runner import CampaignResult
from liaison_cli.storage import write_parquet_atomic, write_text_atomic


def provenance(result: CampaignResult, scenario_text: str, extra: dict | None = None) -> dict:
    scenario = result.scenario
    meta = {
        "package": "liaison",
        "package_version": __version__,
        "scenario_name": scenario.name,
        "scenario_yaml": scenario_text,
        "scenario_effective": scenario.model_dump(mode="json"),
        "seed": scenario.monte_carlo.seed,
        "runs": len(result.outcomes),
        "sigma_m": result.problem.sigma_m,
        "seeding": "numpy SeedSequence(seed, spawn_key=(run,)); initial error drawn first, then noise",
    }
    meta.update(extra or {})
    return meta


def summary_table(result: CampaignResult) -> pd.DataFrame:
    rows = []
    for outcome in result.outcomes:
        per_sc = outcome.summary or [{"spacecraft": name} for name in result.problem.spacecraft]
        for row in per_sc:
            rows.append(
                {"run": outcome.run, **row, "status": outcome.status, "reason": outcome.reason,
                 "fail_time_s": outcome.fail_time_s}
            )
    df = pd.DataFrame(rows)
    return df.astype({"run": "int32"})


def timeseries_table(result: CampaignResult, float_dtype="float32") -> pd.DataFrame:
    """One row per (run, epoch, spacecraft): error norms, 3-sigma bounds, whole-state NEES."""
    times = result.problem.times_s
    names = result.problem.spacecraft
    frames = []
    for outcome in result.outcomes:
        if not outcome.norms:
            continue
        m, n_sc = outcome.norms["position_error_m"].shape
        frame = {
            "run": np.full(m * n_sc, outcome.run, dtype=np.int32),
            "t_s": np.repeat(times, n_sc),
            "spacecraft": np.tile(np.array(names, dtype=object), m),
        }
        for key in ("position_error_m", "velocity_error_m_s", "position_3sigma_m", "velocity_3sigma_m_s"):
            frame[key] = outcome.norms[key].reshape(-1).astype(float_dtype)
        frame["nees"] = np.repeat(outcome.nees, n_sc).astype(float_dtype)
        frames.append(pd.DataFrame(frame))
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def residuals_table(result: CampaignResult, float_dtype="float32") -> pd.DataFrame:
    """One row per (run, epoch, measurement channel): innovation (observed minus predicted) and its
    predicted standard deviation, in the channel's unit (m for range, m/s for range-rate, rad for angles)."""
    problem = result.problem
    times = problem.times_s[1:]
    channels = problem.channel_labels
    links = np.array([c[0] for c in channels], dtype=object)
    observables = np.array([c[1] for c in channels], dtype=object)
    units = np.array([c[2] for c in channels], dtype=object)
    frames = []
    for outcome in result.outcomes:
        if outcome.innovation_m is None:
            continue
        m, n_channels = outcome.innovation_m[1:].shape
        frames.append(
            pd.DataFrame(
                {
                    "run": np.full(m * n_channels, outcome.run, dtype=np.int32),
                    "t_s": np.repeat(times, n_channels),
                    "link": np.tile(links, m),
                    "observable": np.tile(observables, m),
                    "unit": np.tile(units, m),
                    "innovation": outcome.innovation_m[1:].reshape(-1).astype(float_dtype),
                    "innovation_std": outcome.innovation_std_m[1:].reshape(-1).astype(float_dtype),
                }
            )
        )
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def bias_table(result: CampaignResult) -> pd.DataFrame:
    """One row per (run, link): true range bias, the filter's final value and 1-sigma (m)."""
    problem = result.problem
    labels = problem.link_labels
    rows = []
    for outcome in result.outcomes:
        if outcome.bias_true_m is None:
            continue
        for l, label in enumerate(labels):
            rows.append({"run": outcome.run, "link": label, "status": outcome.status,
                         "bias_true_m": float(outcome.bias_true_m[l]),
                         "bias_estimate_m": float(outcome.bias_estimate_m[l]),
                         "bias_sigma_m": float(outcome.bias_sigma_m[l]),
                         "treatment": problem.scenario.filter.bias})
    return pd.DataFrame(rows)


def clock_table(result: CampaignResult, float_dtype="float32") -> pd.DataFrame:
    """One row per (run, epoch, estimated clock): phase error and 1-sigma in ns, frequency error and 1-sigma
    (dimensionless, s/s). Empty when the scenario has no clock."""
    problem = result.problem
    owners = np.array([c.owner for c in problem.clocks], dtype=object)
    frames = []
    for outcome in result.outcomes:
        if outcome.clock_error_s is None:
            continue
        m, n_clocks, _ = outcome.clock_error_s.shape
        frames.append(pd.DataFrame({
            "run": np.full(m * n_clocks, outcome.run, dtype=np.int32),
            "t_s": np.repeat(problem.times_s, n_clocks),
            "clock": np.tile(owners, m),
            "phase_error_ns": (1e9 * outcome.clock_error_s[:, :, 0]).reshape(-1).astype(float_dtype),
            "phase_sigma_ns": (1e9 * outcome.clock_sigma_s[:, :, 0]).reshape(-1).astype(float_dtype),
            "frequency_error": outcome.clock_error_s[:, :, 1].reshape(-1).astype(float_dtype),
            "frequency_sigma": outcome.clock_sigma_s[:, :, 1].reshape(-1).astype(float_dtype),
        }))
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def consistency_table(result: CampaignResult) -> pd.DataFrame:
    """Run-averaged NEES per epoch over the runs that finished, with its 95 % chi-square band."""
    good = [o for o in result.outcomes if o.status == "ok"]
    if not good:
        return pd.DataFrame()
    nees = np.stack([o.nees for o in good])
    state_size = result.problem.filter.n_nees  # the states the NEES covers (consider parameters excluded)
    lo, hi = nees_band(state_size, len(good))
    mean = nees.mean(axis=0)
    return pd.DataFrame(
        {
            "t_s": result.problem.times_s,
            "mean_nees": mean,
            "band_low": lo,
            "band_high": hi,
            "inside_band": (mean >= lo) & (mean <= hi),
            "runs": len(good),
            "state_size": state_size,
        }
    )


def write_campaign(result: CampaignResult, out_dir, scenario_text: str, float_dtype="float32") -> dict:
    """Write summary / timeseries / residuals / consistency Parquet and the scenario text. Returns paths."""
    out_dir = Path(out_dir)
    meta = provenance(result, scenario_text, {"float_dtype": float_dtype})
    paths = {
        "summary": out_dir / "summary.parquet",
        "timeseries": out_dir / "timeseries.parquet",
        "residuals": out_dir / "residuals.parquet",
        "consistency": out_dir / "consistency.parquet",
        "bias": out_dir / "bias.parquet",
        "clocks": out_dir / "clocks.parquet",
    }
    write_parquet_atomic(summary_table(result), paths["summary"], meta)
    write_parquet_atomic(timeseries_table(result, float_dtype), paths["timeseries"], meta)
    write_parquet_atomic(residuals_table(result, float_dtype), paths["residuals"], meta)
    write_parquet_atomic(consistency_table(result), paths["consistency"], meta)
    write_parquet_atomic(bias_table(result), paths["bias"], meta)
    write_parquet_atomic(clock_table(result, float_dtype), paths["clocks"], meta)
    write_text_atomic(scenario_text, out_dir / "scenario.yaml")
    return paths
