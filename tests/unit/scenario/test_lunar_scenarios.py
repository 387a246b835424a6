"""The shipped lunar scenarios (scenarios/lunar/): each validates, ships per spacecraft the process noise that
`python -m benchmarks.lunar_field_truncation --scenarios` chose for it (results/reference/lunar_consistency.md),
and (-m slow) runs by name from an empty folder."""

import re

import pytest

from liaison_cli.scenario.loading import load_scenario
from tests.conftest import REPO, SCENARIOS, run_cli

LUNAR = sorted((SCENARIOS / "lunar").glob("*.yaml"))
TABLE = REPO / "results" / "reference" / "lunar_consistency.md"


def _table_rows() -> dict:
    """{(scenario, spacecraft): shipped PSD} from the reference table."""
    rows = {}
    for line in TABLE.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 9 and re.fullmatch(r"\d[\d.e+-]*", cells[4]):
            rows[(cells[0], cells[1])] = float(cells[4])
    return rows


def test_three_lunar_formations_ship():
    assert [p.stem for p in LUNAR] == ["dro_elfo", "elfo_pair", "relay_nrho_llo"]


@pytest.mark.parametrize("path", LUNAR, ids=lambda p: p.stem)
def test_each_ships_the_process_noise_the_scan_chose(path):
    scenario, _ = load_scenario(path)
    rows = _table_rows()
    for sc in scenario.spacecraft:
        assert (f"lunar/{path.stem}", sc.name) in rows, (path.stem, sc.name)
        assert sc.process_noise_psd_m2_s3 == pytest.approx(rows[(f"lunar/{path.stem}", sc.name)], rel=0.01)
    assert scenario.moon_gravity is not None


@pytest.mark.slow
@pytest.mark.parametrize("path", LUNAR, ids=lambda p: p.stem)
def test_each_runs_by_name_from_an_empty_folder(path, tmp_path):
    proc = run_cli("run", f"lunar/{path.stem}", "--runs", "2", "--jobs", "1", "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "2/2 runs ok" in proc.stdout and (tmp_path / "results" / path.stem / "summary.parquet").is_file()
