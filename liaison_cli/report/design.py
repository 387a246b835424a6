"""`liaison design`'s results (campaign.studies.design) as a ranked text table, the score over the family's
period x phase plane and, with condition numbers, the Pareto front of score and condition number. Formats and
draws only."""

import math
from pathlib import Path

import numpy as np


def format_ranking(table, objective: str, shown: int = 10, factors=(), converge_below_m=None) -> str:
    """Markdown: the best `shown` candidates in rank order (by the LinCov score, or by the range condition number
    with objective `condition`: then the score is the worst spacecraft's), with their Monte Carlo check where it
    was run, `pareto` marking the Pareto front of score and condition number; then that front in full, and the
    candidates that could not be scored, with their reason. With a threshold, the day the error falls below it
    (ranked by) comes first."""
    position = "worst" if objective == "condition" else objective
    converging = converge_below_m is not None
    extra = "".join(f" {key} |" for key in factors)  # the --choices and --vary factors' values, a column each
    extra += f" below {converge_below_m:g} m from (d) |" if converging else ""
    lines = [f"| rank | family | period d | phase |{extra} LinCov {position} RMS m | range condition number | Pareto | "
             "Monte Carlo RMS m | MC / LinCov | runs ok | consistent |",
             "|---|---|---|---|" + "---|" * (len(factors) + converging) + "---|---|---|---|---|---|---|"]
    scored = table[table["rank"] > 0]
    for row in scored.head(shown).to_dict("records"):
        checked = "mc_score_m" in row and isinstance(row["mc_score_m"], float) and math.isfinite(row["mc_score_m"])
        condition = row.get("range_condition_number", math.nan)
        values = "".join(f" {row[key]} |" for key in factors)
        values += f" {_day(row['converge_days'])} |" if converging else ""
        orbit = (f"{row['family']} | {row['period_days']:g} | {row['phase']:g}" if row["family"] else "– | – | –")
        head = (f"| {row['rank']} | {orbit} |{values} "
                f"{row['score_m']:.4g} | {f'{condition:.3g}' if condition == condition else '–'} | "
                f"{'yes' if row.get('pareto') else ''} |")
        lines.append(f"{head} {row['mc_score_m']:.4g} | {row['mc_over_lincov']:.2f} | {row['mc_runs_ok']} | "
                     f"{row['mc_consistent']} |" if checked else f"{head} | | | |")
    front = table[table.pareto] if "pareto" in table else table.iloc[:0]
    if len(front):
        lines.append(f"\nPareto front of the LinCov {position} RMS and the range condition number ({len(front)} of "
                     f"{int(table.score_m.notna().sum())} scored; by error):")
        lines += [f"- candidate {row['candidate']} ({_described(row, factors)}): {row['score_m']:.4g} m, "
                  f"condition {row['range_condition_number']:.3g}"
                  for row in front.sort_values("score_m").to_dict("records")]
    failed = table[table["rank"] == 0]
    if len(failed):
        lines.append(f"\nNot scored ({len(failed)} of {len(table)}):")
        lines += [f"- candidate {row['candidate']} ({_described(row, factors)}): "
                  f"{row['error'] or 'no range condition number (liaison observability refuses this scenario)'}"
                  for row in failed.to_dict("records")]
    return "\n".join(lines) + "\n"


def _day(days: float) -> str:
    return "never" if days == math.inf else f"{days:.2f}"


def format_agreement(rho: float, verified: int, by_condition: float) -> str:
    """The ranking's closing lines: Spearman's rho of the LinCov score against the Monte Carlo RMS over the verified
    candidates, and of the condition number against the score over every scored one (each only when known)."""
    text = (f"\nSpearman rank correlation, LinCov score against Monte Carlo RMS over the {verified} verified: "
            f"{rho:.2f}\n" if rho == rho else "")
    if by_condition == by_condition:
        text += (f"Spearman rank correlation, range condition number against LinCov score over every scored "
                 f"candidate: {by_condition:.2f}\n")
    return text


def _described(row, factors) -> str:
    """A candidate in words: its family member and phase, and its factors' values."""
    parts = [f"{row['family']} {row['period_days']:g} d, phase {row['phase']:g}"] if row["family"] else []
    return ", ".join(parts + [f"{key} = {row[key]}" for key in factors])


def draw_score_plane(table, path: Path, title: str) -> Path | None:
    """The LinCov score (log colour) over period x phase (the best over any other factors); None with a single
    period and phase, or no orbit family."""
    if not table.family.astype(bool).any():
        return None
    periods, phases = np.unique(table.period_days), np.unique(table.phase)
    if len(periods) * len(phases) < 2:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LogNorm

    grid = np.full((len(phases), len(periods)), np.nan)
    for row in table.to_dict("records"):  # with other factors (--vary): the best over them in each cell
        cell = np.searchsorted(phases, row["phase"]), np.searchsorted(periods, row["period_days"])
        grid[cell] = np.fmin(grid[cell], row["score_m"])
    fig, ax = plt.subplots(figsize=(7, 4.5))
    finite = grid[np.isfinite(grid) & (grid > 0)]
    norm = LogNorm(vmin=finite.min(), vmax=finite.max()) if finite.size and finite.max() > finite.min() else None
    mesh = ax.pcolormesh(_edges(periods), _edges(phases), np.ma.masked_invalid(grid), norm=norm, cmap="viridis_r")
    fig.colorbar(mesh, ax=ax, label="LinCov position error RMS after settle (m)")
    best = table[table.score_m.notna()].head(1)
    if len(best):
        ax.plot(best.period_days, best.phase, marker="*", color="red", markersize=14, label="ranked first")
        ax.legend(loc="upper right", fontsize=9)
    ax.set_xlabel("period (days)")
    ax.set_ylabel("phase (fraction of the period)")
    return _saved(fig, ax, title, path)


def _saved(fig, ax, title: str, path: Path) -> Path:
    """The figure titled and written to `path` (PNG, 120 dpi) through a temporary file, then closed."""
    import matplotlib.pyplot as plt

    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    tmp = path.with_name(f".{path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    tmp.replace(path)
    plt.close(fig)
    return path


def draw_pareto(table, path: Path, title: str) -> Path | None:
    """The LinCov position error against the range condition number, log-log, every scored candidate, the Pareto
    front joined and marked; None without condition numbers."""
    known = table[np.isfinite(table.score_m.astype(float)) & np.isfinite(table.range_condition_number.astype(float))]
    if len(known) < 2:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    front = known[known.pareto].sort_values("range_condition_number")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.scatter(known.range_condition_number, known.score_m, s=14, color="0.5", label="candidate")
    ax.plot(front.range_condition_number, front.score_m, "o-", color="tab:red", markersize=5,
            label=f"Pareto front ({len(front)})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("range information condition number")
    ax.set_ylabel("LinCov position error RMS after settle (m)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=9)
    return _saved(fig, ax, title, path)


def _edges(values) -> np.ndarray:
    """Cell edges around sorted centres (one centre: +-0.5)."""
    values = np.asarray(values, dtype=float)
    if len(values) == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    middle = 0.5 * (values[1:] + values[:-1])
    return np.concatenate([[2 * values[0] - middle[0]], middle, [2 * values[-1] - middle[-1]]])
