"""The formation-geometry study (campaign.studies.geometry) as heat maps: per grid, the log10 of the pairs'
condition numbers for range and range-rate links (PNG). Draws only."""

from pathlib import Path

import numpy as np
import pandas as pd


def draw_heatmaps(table: pd.DataFrame, title: str, path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first = table.drop_duplicates("i").sort_values("i")["first"].tolist()
    second = table.drop_duplicates("j").sort_values("j")["second"].tolist()
    fig, axes = plt.subplots(1, 2, figsize=(14, 6), constrained_layout=True)
    for ax, observable in zip(axes, ("range", "range_rate")):
        grid = np.full((len(first), len(second)), np.nan)
        for row in table.itertuples():
            grid[row.i, row.j] = np.log10(getattr(row, f"{observable}_condition_number"))
        image = ax.imshow(grid, origin="lower", cmap="magma_r")
        for i in range(len(first)):
            for j in range(len(second)):
                ax.text(j, i, f"{grid[i, j]:.1f}", ha="center", va="center", fontsize=7,
                        color="white" if grid[i, j] > np.nanmean(grid) else "black")
        ax.set_xticks(range(len(second)), second, rotation=45, ha="right", fontsize=8)
        ax.set_yticks(range(len(first)), first, fontsize=8)
        ax.set_title(f"{observable.replace('_', '-')} links: log10 condition number")
        fig.colorbar(image, ax=ax, shrink=0.8, label="log10 cond(Λ)")
    fig.suptitle(title)
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def draw_study(tables: dict, titles: dict, interval_s: float, folder) -> list[Path]:
    """Each grid's heat map, `folder/<key>.png`; `titles`: {key: the grid's title}."""
    return [draw_heatmaps(table, f"{titles[key]}: observability over the longer period ({interval_s:g} s sampling)",
                          Path(folder) / f"{key}.png") for key, table in tables.items()]
