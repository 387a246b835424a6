"""The error budget (campaign.studies.error_budget) as the tables `liaison errors` writes, its provenance, and its
parts grouped by source for the figure (report.error_budget draws it)."""

import numpy as np
import pandas as pd

from liaison_cli.campaign.studies.error_budget import Budget, BudgetStudy, part_of
from liaison_cli.provenance import arithmetic_provenance


def budget_table(budget: Budget) -> pd.DataFrame:
    """One row per (epoch, spacecraft, part): position m^2, velocity (m/s)^2 contributions, and the total."""
    frames = []
    m, n_sc, _ = budget.total.shape
    for name, values in {**budget.parts, "total": budget.total, "filter_covariance": budget.filter_variance}.items():
        frames.append(pd.DataFrame({
            "t_s": np.repeat(budget.times_s, n_sc),
            "spacecraft": np.tile(np.array(budget.spacecraft, dtype=object), m),
            "part": name,
            "source": name if name in ("total", "filter_covariance") else part_of(name),
            "position_m2": values[:, :, 0].reshape(-1),
            "velocity_m2_s2": values[:, :, 1].reshape(-1),
        }))
    return pd.concat(frames, ignore_index=True)


def shares_frame(rows, late=None) -> pd.DataFrame:
    """Rows as a table; with `late` (the after-day-1 rows), their shares as extra columns."""
    frame = pd.DataFrame(rows)
    if late is not None:
        other = pd.DataFrame(late).set_index(["spacecraft", "part"])
        for column in ("position_share", "velocity_share"):
            frame[f"{column}_after_day1"] = [other.loc[(r.spacecraft, r.part), column] for r in frame.itertuples()]
    return frame


def budget_tables(study: BudgetStudy) -> dict:
    """{stem: table}: budget, shares, the Monte Carlo check (when run) and consistency."""
    tables = {"budget": budget_table(study.budget), "shares": shares_frame(study.rows_all, study.rows_late)}
    if study.checks:
        tables["monte_carlo_check"] = shares_frame(study.checks)
    tables["consistency"] = pd.DataFrame(study.consistency_rows)
    return tables


def provenance(scenario_name: str, scenario_yaml: str) -> dict:
    """The metadata of the budget's Parquet tables."""
    return {"package": "liaison", "arithmetic": arithmetic_provenance(), "scenario": scenario_name,
            "scenario_yaml": scenario_yaml,
            "method": "LinCov along the truth with the filter's own gains; parts in m^2 and (m/s)^2"}


def by_source(budget: Budget) -> dict:
    """{source: (m, n_sc, 2)}: the budget's parts summed per source (part_of), in the order they first appear."""
    grouped = {}
    for name, values in budget.parts.items():
        grouped.setdefault(part_of(name), np.zeros_like(values))
        grouped[part_of(name)] = grouped[part_of(name)] + values
    return grouped
