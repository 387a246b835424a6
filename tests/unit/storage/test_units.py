"""Column units in the Arrow field metadata of every table liaison writes (storage.units)."""

import numpy as np
import pandas as pd
import pytest

from liaison_cli.storage import unit_of, units_of_file, write_columns_atomic, write_parquet_atomic


@pytest.mark.parametrize("name, unit", [
    ("t_s", "s"), ("rms_position_m", "m"), ("velocity_3sigma_m_s", "m/s"), ("snc_m_s2", "m/s^2"),
    ("psd_m2_s3", "m^2/s^3"), ("vx_km_s", "km/s"), ("x_km", "km"), ("phase_error_ns", "ns"),
    ("rms_position_after_day1_m_p90", "m"), ("clock_rms_window_ns_mean", "ns"), ("time_shift_lag_s_settled", "s"),
    ("settle_days", "d"), ("initial_batch_window_h", "h"), ("measurement.interval_s", "s"),
    ("rms_accel_error_settled_m_s2", "m/s^2"), ("interval_min", "min"), ("days_below_1cm_s", "d"),
])
def test_units_read_from_names(name, unit):
    assert unit_of(name) == unit


@pytest.mark.parametrize("name", ["run", "spacecraft", "nees", "runs_ok", "frac_in_2sigma", "corr_xy",
                                  "frac_nees_in_band_settled", "innovations_settled", "position_error_to_sigma",
                                  "frequency_error", "case", "s", "mu2_per_s", "sigma1_s_per_sqrt_s",
                                  "initial_batch_chi2_per_measurement"])
def test_counts_shares_and_labels_have_no_unit(name):
    assert unit_of(name) is None


def test_both_writers_store_units(tmp_path):
    columns = {"run": np.arange(3, dtype=np.int32), "t_s": np.zeros(3), "error_vx_m_s": np.ones(3, dtype=np.float32),
               "spacecraft": np.array(["a", "b", None], dtype=object)}
    write_columns_atomic(columns, tmp_path / "a.parquet", {"k": 1})
    write_parquet_atomic(pd.DataFrame(columns), tmp_path / "b.parquet", {"k": 1})
    for name in ("a", "b"):
        assert units_of_file(tmp_path / f"{name}.parquet") == {"t_s": "s", "error_vx_m_s": "m/s"}
        assert pd.read_parquet(tmp_path / f"{name}.parquet").error_vx_m_s.tolist() == [1.0, 1.0, 1.0]
