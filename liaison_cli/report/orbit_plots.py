"""Pictures of orbit families: the members in three projections of the rotating frame, coloured by period."""

from pathlib import Path

import numpy as np

from liaison_cli.dynamics.constants import LU_KM, MU
from liaison_cli.dynamics.integrators.dop853 import dop853_states
from liaison_cli.orbits.families import TU_DAYS
from liaison_cli.orbits.periodic import lagrange_point_x


def draw_family(name: str, members, out_path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import cm
    from matplotlib.colors import Normalize

    periods = np.array([m.period_tu * TU_DAYS for m in members])
    norm = Normalize(periods.min(), periods.max())
    cmap = plt.get_cmap("viridis")
    fig, axes = plt.subplots(1, 3, figsize=(15, 5.2), constrained_layout=True)
    planes = (("x", "y", 0, 1), ("x", "z", 0, 2), ("y", "z", 1, 2))
    for orbit, days in zip(members, periods):
        states = dop853_states(np.array(orbit.state), np.linspace(0.0, orbit.period_tu, 600), MU)
        for ax, (_, _, i, j) in zip(axes, planes):
            ax.plot(states[:, i] * LU_KM / 1e3, states[:, j] * LU_KM / 1e3, color=cmap(norm(days)), lw=0.8)
    moon = np.array([1.0 - MU, 0.0, 0.0]) * LU_KM / 1e3
    for ax, (a, b, i, j) in zip(axes, planes):
        ax.add_patch(plt.Circle((moon[i], moon[j]), 1.7374, color="0.4"))
        for point in (1, 2):
            xl = np.array([lagrange_point_x(point), 0.0, 0.0]) * LU_KM / 1e3
            ax.plot(xl[i], xl[j], "k+", ms=8)
        ax.set_xlabel(f"{a} [10³ km]")
        ax.set_ylabel(f"{b} [10³ km]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    fig.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), ax=axes, label="period [days]", shrink=0.8)
    fig.suptitle(f"{name}: {len(members)} members, Earth–Moon rotating frame (Moon grey, L1/L2 +)")
    out_path = Path(out_path)
    out_path.parent.mkdir(parents=True, exist_ok=True)
    tmp = out_path.with_name(f".{out_path.name}.tmp.png")
    fig.savefig(tmp, dpi=120)
    tmp.replace(out_path)
    plt.close(fig)
    return out_path
