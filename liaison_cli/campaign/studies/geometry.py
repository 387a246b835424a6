"""Formation-geometry study (001 §6.5): observability of every pairing of orbits from two families.

For each pair the information matrix of a single crosslink is accumulated over the longer of the two
periods (sampled every `interval_s`); its condition number is reported for range and for range-rate links.
Grids: 7 EML1 x 7 EML2 southern halos, and 7 EML2 southern halos x 7 lunar orbiters (semi-major axis
varied, the eml2_lunar scenario's e = 0.4, i = 60 deg, starting at perilune). report.geometry draws the
heat maps; `liaison geometry` writes the tables (campaign.studies.output).
"""

import numpy as np
import pandas as pd

from liaison_cli.analysis.observability import analyse, stm_from_t0
from liaison_cli.dynamics.constants import LU_KM, M_PER_LU, M_S_PER_VU, SECONDS_PER_DAY, TU_S
from liaison_cli.orbits.families import TU_DAYS
from liaison_cli.orbits.family_store import from_table, load_or_generate
from liaison_cli.orbits.keplerian import keplerian_period_s, lunar_orbiter_state_lu
from liaison_cli.provenance import arithmetic_provenance

LUNAR_A_KM = (5000.0, 6500.0, 8000.0, 9000.0, 11000.0, 13000.0, 15000.0)


def _pick(family: str, count: int):
    members = from_table(load_or_generate(family)[0])
    picks = np.round(np.linspace(0, len(members) - 1, count)).astype(int)
    return [members[i] for i in picks]


def _orbits(kind: str, count: int):
    """[(label, state0 (6,), period_s)]"""
    if kind == "lunar":
        out = []
        for a_km in LUNAR_A_KM[:count]:
            state = lunar_orbiter_state_lu(a_km, 0.4, 60.0, 0.0, 0.0, 0.0)
            out.append((f"lunar a={a_km:.0f} km", state, keplerian_period_s(a_km)))
        return out
    return [(f"{kind} {o.period_tu * TU_DAYS:.2f} d", np.array(o.state), o.period_tu * TU_S) for o in _pick(kind, count)]


def geometry_study(first: str, second: str, count: int = 7, interval_s: float = 600.0,
                   sigma_range_m: float = 150.0, sigma_range_rate_m_s: float = 1e-3) -> pd.DataFrame:
    rows = []
    left, right = _orbits(first, count), _orbits(second, count)
    for i, (label_a, state_a, period_a) in enumerate(left):
        for j, (label_b, state_b, period_b) in enumerate(right):
            duration_s = max(period_a, period_b)
            times_tu = np.arange(0.0, duration_s + 1e-9, interval_s) / TU_S
            states0 = np.array([state_a, state_b])
            propagated = stm_from_t0(states0, times_tu)
            row = {"first": label_a, "second": label_b, "i": i, "j": j, "duration_days": duration_s / SECONDS_PER_DAY,
                   "first_period_days": period_a / SECONDS_PER_DAY, "second_period_days": period_b / SECONDS_PER_DAY,
                   "mean_distance_km": float(np.mean(np.linalg.norm(
                       propagated[0][:, 0, :3] - propagated[0][:, 1, :3], axis=1)) * LU_KM)}
            for observable, sigma in (("range", sigma_range_m / M_PER_LU),
                                      ("range_rate", sigma_range_rate_m_s / M_S_PER_VU)):
                result = analyse(states0, times_tu, [(0, 1)], sigma, observable, propagated=propagated)
                row[f"{observable}_condition_number"] = result.condition_number
                row[f"{observable}_unobservability_index"] = result.unobservability_index
            rows.append(row)
    return pd.DataFrame(rows)


# The study's two grids: key -> (first family, second family, title).
GRIDS = {
    "l1_l2_halo": ("l1_halo_south", "l2_halo_south", "EML1 halo x EML2 halo (southern families)"),
    "l2_halo_lunar": ("l2_halo_south", "lunar", "EML2 halo x lunar orbiter (e 0.4, i 60 deg, a varied)"),
}


def geometry_tables(count: int = 7, interval_s: float = 600.0) -> dict:
    """Every grid's table (geometry_study), by GRIDS key."""
    return {key: geometry_study(first, second, count, interval_s) for key, (first, second, _) in GRIDS.items()}


def provenance(count: int, interval_s: float) -> dict:
    """The metadata of each grid's Parquet (with "study": its GRIDS key)."""
    return {"package": "liaison", "arithmetic": arithmetic_provenance(), "interval_s": interval_s, "count": count}
