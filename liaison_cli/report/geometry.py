"""The formation-geometry study (campaign.geometry) as tables and heat maps: per grid, the pairs'
condition numbers for range and range-rate links (Parquet) and their log10 as a heat map (PNG)."""

from pathlib import Path

import numpy as np
import pandas as pd

from liaison_cli.campaign.geometry import GRIDS, geometry_study
from liaison_cli.provenance import arithmetic_provenance
from liaison_cli.storage import write_parquet_atomic


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


def run_study(out_dir, count: int = 7, interval_s: float = 600.0) -> dict:
    out_dir = Path(out_dir)
    outputs = {}
    for key, (first, second, title) in GRIDS.items():
        table = geometry_study(first, second, count, interval_s)
        meta = {"package": "liaison", "arithmetic": arithmetic_provenance(), "study": key, "interval_s": interval_s,
                "count": count}
        write_parquet_atomic(table, out_dir / f"{key}.parquet", meta)
        draw_heatmaps(table, f"{title}: observability over the longer period ({interval_s:g} s sampling)",
                      out_dir / f"{key}.png")
        outputs[key] = table
    return outputs
