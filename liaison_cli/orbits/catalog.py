"""Named initial states in the Earth-Moon CRTBP (rotating frame, LU and LU/TU).

`eml2_halo` and `eml1_halo` are Turan et al. (2022) Table 1. Their y = 0 return times are the
periods quoted in the catalog (measured with the constants of `dynamics.constants`).
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CatalogOrbit:
    name: str
    state_lu: tuple[float, float, float, float, float, float]
    period_tu: float
    source: str

    def state(self) -> np.ndarray:
        return np.array(self.state_lu, dtype=float)


CATALOG: dict[str, CatalogOrbit] = {
    orbit.name: orbit
    for orbit in (
        CatalogOrbit(
            "eml2_halo",
            (1.1785868, 0.0, -0.0468605, 0.0, -0.1673971, 0.0),
            3.39739,
            "Turan et al. 2022, Table 1 (southern EML2 halo, ~14.75 d)",
        ),
        CatalogOrbit(
            "eml1_halo",
            (0.8614062, 0.0, 0.03140426, 0.0, -0.1608423, 0.0),
            2.75211,
            "Turan et al. 2022, Table 1 (southern EML1 halo, ~11.95 d; z < 0 at its far crossing)",
        ),
    )
}


def catalog_names() -> list[str]:
    return sorted(CATALOG)
