"""Every scenario of scenarios/ gives the per-run numbers and printed output of tests/golden/runs.json.gz
(first recorded at 432c588, before the engine restructuring of issue 11; re-recorded since, each time for
a stated reason: see tests/golden/record.py): Parquet values equal to 1e-7 relative (absolute floor 1e-7 of
the column's largest value, for values near zero). 1e-7, not tighter: the same code under newer numpy /
numba builds moves the mean NEES of the star scenarios by 1.5e-8 relative (a different summation order
in a library), while a change of the models or of a draw moves them by 1e-6 or more."""

import gzip
import json

import numpy as np
import pytest

from tests.golden.record import GOLDEN, ROOT, run_scenario

with gzip.open(GOLDEN, "rt", encoding="utf-8") as _handle:
    RECORDED = json.load(_handle)

RTOL = 1e-7


def _close(name, got, want):
    got = np.array([np.nan if v is None else v for v in got], dtype=float)
    want = np.array([np.nan if v is None else v for v in want], dtype=float)
    assert got.shape == want.shape, name
    assert np.array_equal(np.isnan(got), np.isnan(want)), name
    scale = np.nanmax(np.abs(want)) if np.isfinite(want).any() else 0.0
    np.testing.assert_allclose(got, want, rtol=RTOL, atol=RTOL * scale, equal_nan=True, err_msg=name)


@pytest.mark.parametrize("scenario", sorted(RECORDED))
def test_scenario_matches_recorded_main(scenario):
    want = RECORDED[scenario]
    got = run_scenario(ROOT / "scenarios" / scenario)
    assert got["stdout"] == want["stdout"]
    for table, recorded in want["tables"].items():
        fresh = got["tables"][table]
        assert fresh["rows"] == recorded["rows"], table
        for column, values in recorded["columns"].items():
            name = f"{scenario} {table}.{column}"
            assert column in fresh["columns"], name
            if "text" in values:
                assert fresh["columns"][column]["text"] == values["text"], name
                continue
            mine = fresh["columns"][column]
            assert mine["nan"] == values["nan"], name
            _close(name, [mine["sum"], mine["abs"]], [values["sum"], values["abs"]])
            _close(name, mine["sample"], values["sample"])
