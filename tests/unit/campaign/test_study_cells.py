"""Issue 35 fault 11: a damaged cell in a study's work folder is computed again with a note, instead of making
every rerun fail until the file is deleted by hand."""

import pandas as pd
import pytest

from liaison_cli.campaign.studies.study_cells import CellStore
from liaison_cli.scenario.loading import load_scenario
from tests.conftest import SCENARIOS


@pytest.mark.parametrize("damage", ["done", "parquet"])
def test_a_damaged_cell_is_computed_again(tmp_path, capsys, damage):
    scenario, _ = load_scenario(SCENARIOS / "smoke.yaml")
    calls = []

    def compute():
        calls.append(1)
        return {"summary": pd.DataFrame({"x": [1.0, 2.0]})}

    store = CellStore(tmp_path, "study", "code")
    first = store.cell("cell", scenario, 2, compute)
    target = next(tmp_path.glob("*.done" if damage == "done" else "*.parquet"))
    target.write_bytes(b"{not json" if damage == "done" else b"PAR1 truncated")
    again = CellStore(tmp_path, "study", "code")
    second = again.cell("cell", scenario, 2, compute)
    assert len(calls) == 2 and (again.computed, again.reused) == (1, 0)
    assert second["summary"].equals(first["summary"])
    assert "is damaged" in capsys.readouterr().err
    third = CellStore(tmp_path, "study", "code")  # rewritten whole: read back now
    third.cell("cell", scenario, 2, compute)
    assert (third.computed, third.reused) == (0, 1) and len(calls) == 2
