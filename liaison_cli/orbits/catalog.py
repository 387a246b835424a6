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
        # Sirbu & Leonardi 2023 (002), Table 1: the 9:2 lunar-synodic-resonant southern L2 NRHO (period
        # 1.5112 TU = 6.59 d in the paper's units), Gateway and two "floating anchors" on it, to the digits
        # printed. In our CRTBP constants the Gateway state returns within 66 km of itself after 1.5112 TU
        # (tests/unit/estimation/test_batch.py); the truth propagates the printed states as given.
        CatalogOrbit("nrho_gateway", (1.0221, 0.0, -0.1821, 0.0, -0.1033, 0.0), 1.5112,
                     "Sirbu & Leonardi 2023, Table 1 (Gateway, 9:2 NRHO)"),
        CatalogOrbit("nrho_anchor_1", (1.01282, -0.03468, -0.14507, -0.04860, -0.06772, 0.20422), 1.5112,
                     "Sirbu & Leonardi 2023, Table 1 (anchor 1, same NRHO)"),
        CatalogOrbit("nrho_anchor_2", (1.01284, 0.03442, -0.14582, 0.04809, -0.06846, -0.20189), 1.5112,
                     "Sirbu & Leonardi 2023, Table 1 (anchor 2, same NRHO)"),
    )
}


def catalog_names() -> list[str]:
    return sorted(CATALOG)
