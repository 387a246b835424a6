"""The paper's design workflow in one step: link budget -> ranging sigma -> expected OD error from a sweep.

Expected errors are read off a sweep's curve by linear interpolation in sigma; a sigma outside the swept
range is reported as such rather than extrapolated.
"""

import numpy as np
import pandas as pd

from liaison_cli.report.fig15 import sigma_series

METHOD_LABELS = {"time_derived": "time-derived (Eq. 4)", "telemetry": "telemetry (Eq. 3)", "pn": "PN (Eq. 1)",
                 "tone": "tone (001 Eq. 62-63)"}
READ_OFF = ("rms_position_m", "rms_velocity_m_s", "rms_position_after_day1_m", "rms_velocity_after_day1_m_s")


def expected_errors(curve: pd.DataFrame, sigma_by_method: dict) -> pd.DataFrame:
    """One row per (method, scenario, spacecraft): interpolated mean and 90th-percentile RMS errors."""
    rows = []
    for method, sigma in sigma_by_method.items():
        if sigma is None:
            continue
        for scenario, spacecraft, series in sigma_series(curve):
            grid = series.sigma_m.to_numpy(dtype=float)
            inside = grid.min() <= sigma <= grid.max()
            row = {"method": method, "sigma_m": sigma, "scenario": scenario, "spacecraft": spacecraft,
                   "inside_swept_range": bool(inside), "swept_min_m": grid.min(), "swept_max_m": grid.max()}
            for metric in READ_OFF:
                for stat in ("mean", "p90"):
                    values = series[f"{metric}_{stat}"].to_numpy(dtype=float)
                    row[f"{metric}_{stat}"] = float(np.interp(sigma, grid, values)) if inside else np.nan
            rows.append(row)
    return pd.DataFrame(rows)
