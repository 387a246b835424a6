"""A scenario's observability (campaign.studies.observability_study computes it) as observability.json and the
000 Fig. 16-17 analogues (PNG). Formats and draws only."""

import json

import numpy as np

from liaison_cli.dynamics.constants import SECONDS_PER_DAY


def summary_json(summary: dict) -> str:
    """observability.json: the summary `liaison observability` prints."""
    return json.dumps(summary, indent=2) + "\n"


def draw_effectiveness(study, path, title: str):
    """The effectiveness figure of an ObservabilityStudy."""
    _plot_effectiveness(study.results, study.names, study.times_s, study.moon_km, path, title)
    return [path]


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
