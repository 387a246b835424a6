"""`liaison design`'s results (campaign.studies.design) as a ranked text table and the score over the family's
period x phase plane. Formats and draws only."""

import math
from pathlib import Path

import numpy as np


def format_ranking(table, objective: str, shown: int = 10) -> str:
    """Markdown: the best `shown` candidates by LinCov score, with their Monte Carlo check where it was run;
    then the candidates that could not be scored, with their reason."""
    lines = [f"| rank | family | period d | phase | LinCov {objective} RMS m | range condition number | "
             "Monte Carlo RMS m | MC / LinCov | runs ok | consistent |", "|---|---|---|---|---|---|---|---|---|---|"]
    scored = table[table.score_m.notna()]
    for row in scored.head(shown).to_dict("records"):
        checked = "mc_score_m" in row and isinstance(row["mc_score_m"], float) and math.isfinite(row["mc_score_m"])
        condition = row.get("range_condition_number", math.nan)
        head = (f"| {row['rank']} | {row['family']} | {row['period_days']:g} | {row['phase']:g} | "
                f"{row['score_m']:.4g} | {f'{condition:.3g}' if condition == condition else '–'} |")
        lines.append(f"{head} {row['mc_score_m']:.4g} | {row['mc_over_lincov']:.2f} | {row['mc_runs_ok']} | "
                     f"{row['mc_consistent']} |" if checked else f"{head} | | | |")
    failed = table[table.score_m.isna()]
    if len(failed):
        lines.append(f"\nNot scored ({len(failed)} of {len(table)}):")
        lines += [f"- period {row['period_days']:g} d, phase {row['phase']:g}: {row['error']}"
                  for row in failed.to_dict("records")]
    return "\n".join(lines) + "\n"


def draw_score_plane(table, path: Path, title: str) -> Path | None:
    """The LinCov score (log colour) over period x phase; None with a single period and phase."""
    periods, phases = np.unique(table.period_days), np.unique(table.phase)
    if len(periods) * len(phases) < 2:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    grid = np.full((len(phases), len(periods)), np.nan)
    for row in table.to_dict("records"):
        grid[np.searchsorted(phases, row["phase"]), np.searchsorted(periods, row["period_days"])] = row["score_m"]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    finite = grid[np.isfinite(grid) & (grid > 0)]
    norm = LogNorm(vmin=finite.min(), vmax=finite.max()) if finite.size and finite.max() > finite.min() else None
    mesh = ax.pcolormesh(_edges(periods), _edges(phases), np.ma.masked_invalid(grid), norm=norm, cmap="viridis_r")
    fig.colorbar(mesh, ax=ax, label="LinCov position error RMS after settle (m)")
    best = table[table.score_m.notna()].head(1)
    if len(best):
        ax.plot(best.period_days, best.phase, marker="*", color="red", markersize=14, label="best")
        ax.legend(loc="upper right", fontsize=9)
    ax.set_xlabel("period (days)")
    ax.set_ylabel("phase (fraction of the period)")
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    tmp.replace(path)
    plt.close(fig)
    return path


def _edges(values) -> np.ndarray:
    """Cell edges around sorted centres (one centre: +-0.5)."""
    values = np.asarray(values, dtype=float)
    if len(values) == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    middle = 0.5 * (values[1:] + values[:-1])
    return np.concatenate([[2 * values[0] - middle[0]], middle, [2 * values[-1] - middle[-1]]])
