"""Observability report of a scenario: tables (Parquet), observability.json and the 000 Fig. 16-17
analogues (PNG), of the analysis campaign.observability_study computes."""

import json
from pathlib import Path

import numpy as np

from liaison_cli.campaign.observability_study import (
    check_supported, known_inputs, observability_study, scenario_inputs)
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.storage import write_parquet_atomic, write_text_atomic

__all__ = ["check_supported", "known_inputs", "observability_report", "scenario_inputs"]


def observability_report(scenario, scenario_text: str, out_dir, range_rate_sigma_m_s: float = 1e-3,
                         taylor: bool = True) -> dict:
    """Run the analysis for range and range-rate links; write tables and plots; return the summary dict."""
    out_dir = Path(out_dir)
    study = observability_study(scenario, range_rate_sigma_m_s, taylor)
    meta = {"package": "liaison", "arithmetic": arithmetic_provenance(), "scenario_yaml": scenario_text,
            "summary": study.summary}
    write_parquet_atomic(study.effectiveness, out_dir / "effectiveness.parquet", meta)
    write_parquet_atomic(study.singular, out_dir / "singular.parquet", meta)
    if study.taylor is not None:
        write_parquet_atomic(study.taylor, out_dir / "taylor_stm.parquet", meta)
    write_text_atomic(json.dumps(study.summary, indent=2) + "\n", out_dir / "observability.json")
    _plot_effectiveness(study.results, study.names, study.times_s, study.moon_km, out_dir / "effectiveness.png",
                        scenario.name)
    return study.summary


def _plot_effectiveness(results, names, times_s, moon_km, path, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    days = times_s / SECONDS_PER_DAY
    fig, axes = plt.subplots(2, 2, figsize=(13, 7.5), sharex=True, constrained_layout=True)
    for col, observable in enumerate(("range", "range_rate")):
        result = results[observable]
        for row, (label, data) in enumerate((("position", result.effectiveness_position),
                                             ("velocity", result.effectiveness_velocity))):
            ax = axes[row, col]
            for s, name in enumerate(names):
                ax.semilogy(days, data[:, s], lw=0.9, label=name)
            ax.set_title(f"{observable.replace('_', '-')} links: {label} effectiveness")
            ax.set_ylabel(f"√max eig Λ_k ({label} block) [nondim.]")
            ax.grid(alpha=0.3, which="both")
    for ax in axes[1]:
        ax.set_xlabel("time [days]")
    axes[0, 0].legend(loc="lower right")
    if "Lunar" in names or any(moon_km[:, s].max() < 30000 for s in range(len(names))):
        s = int(np.argmin(moon_km.max(axis=0)))
        d = moon_km[:, s]
        peri = np.where((d[1:-1] < d[:-2]) & (d[1:-1] < d[2:]))[0] + 1
        apo = np.where((d[1:-1] > d[:-2]) & (d[1:-1] > d[2:]))[0] + 1
        for ax in axes.ravel():
            for k in peri:
                ax.axvline(days[k], color="0.55", lw=0.7, ls=":")
            for k in apo:
                ax.axvline(days[k], color="0.8", lw=0.7, ls="--")
        axes[0, 1].text(0.01, 0.02, f"{names[s]}: perilune dotted, apolune dashed", transform=axes[0, 1].transAxes,
                        fontsize=8, color="0.3")
    fig.suptitle(f"{title}: observation effectiveness, mapped to t0 (cf. Turan et al. 2022, Fig. 16-17)")
    fig.savefig(path, dpi=120)
    plt.close(fig)
