"""Scenarios and studies that fly the same orbit over the same span share one corrected orbit on disk (issue 37,
item 3): the cache key is made of the correction's inputs (state, epoch, span, spacing, force model), not of the
scenario, so the second one reads what the first corrected. The corrector is replaced by a counting stand-in:
this tests the keying, not the correction (tests/unit/orbits/test_corrected_store.py does that)."""

import numpy as np
import pytest

from liaison_cli.orbits import corrected_store
from liaison_cli.orbits.ephemeris_correction import CorrectedOrbit
from liaison_cli.scenario.dated import corrected_nodes_lu, dated_model
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from tests.conftest import SCENARIOS


@pytest.fixture
def corrections(tmp_path, monkeypatch):
    """An empty cache and a stand-in corrector that records its calls (converged, two nodes)."""
    monkeypatch.setenv("LIAISON_CACHE_DIR", str(tmp_path))
    calls = []

    def counted(state_lu, epoch_s, span_s, spacing_s, forces, steps_per_node, max_iterations, period_tu):
        calls.append((epoch_s, span_s))
        nodes = np.tile(np.asarray(state_lu, dtype=float), (2, 1))
        return CorrectedOrbit(np.array([epoch_s, epoch_s + span_s]), nodes, (0.0,), (0.0,), 1, True)

    monkeypatch.setattr(corrected_store, "corrected_in_stages", counted)
    return calls


def _correct(scenario, name: str):
    spacecraft = next(sc for sc in scenario.spacecraft if sc.name == name)
    return corrected_nodes_lu(spacecraft, scenario, dated_model(scenario))


def test_a_second_scenario_flying_the_same_orbit_does_not_correct_it_again(corrections):
    """003's MSL case and the dated golden scenario both fly the EML1 halo from the same epoch over 9 days."""
    msl, _ = load_scenario(SCENARIOS / "003" / "msl.yaml")
    golden, _ = load_scenario(SCENARIOS / "eph_eml1_eml2_dsn.yaml")
    first = _correct(msl, "EML1")
    second = _correct(golden, "EML1")
    assert len(corrections) == 1
    assert all(np.array_equal(a, b) for a, b in zip(first, second))
    _correct(golden, "EML2")  # another orbit: corrected
    assert len(corrections) == 2


def test_a_study_cell_of_one_link_shares_its_scenarios_corrections(corrections):
    """study004 runs each receiver pair of a transmitter alone: the same spacecraft over the same span, so the
    transmitter's and the receivers' orbits are corrected once for all of its pairs."""
    halo, _ = load_scenario(SCENARIOS / "004" / "eml2_halo.yaml")
    for index, link in enumerate(halo.links):
        cell = apply_overrides(halo, {"links": [link.model_dump(exclude_none=True)], "name": f"pair{index}"}, "test")
        for name in ("TX", "L1A", "L1B"):
            _correct(cell, name)
    assert len(corrections) == 3

