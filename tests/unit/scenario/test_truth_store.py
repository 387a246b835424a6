"""scenario.truth_store: a spacecraft's CRTBP truth flown once per machine, read back bit for bit in another
process or session; a damaged entry is one note and computed again; off when asked."""

import numpy as np
import pytest

from liaison_cli.scenario import truth as truth_module
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.scenario.setup import prepare_problem
from tests.conftest import SCENARIOS


@pytest.fixture
def scenario():
    return apply_overrides(load_scenario(SCENARIOS / "smoke.yaml")[0], {"duration_days": 0.5})


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LIAISON_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("LIAISON_TRUTH_CACHE", raising=False)
    return tmp_path / "truths"


def _no_flying(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("flown again")

    monkeypatch.setattr(truth_module, "_flown", refuse)


def test_a_truth_is_flown_once_and_read_back_bit_for_bit(scenario, cache, monkeypatch):
    first = prepare_problem(scenario).truth
    assert len(list(cache.glob("*.npz"))) == 2  # one per spacecraft
    _no_flying(monkeypatch)
    second = prepare_problem(scenario).truth
    assert np.array_equal(first, second)


def test_a_damaged_entry_is_one_note_and_flown_again(scenario, cache, capsys):
    first = prepare_problem(scenario).truth
    for path in cache.glob("*.npz"):
        path.write_bytes(path.read_bytes()[:100])  # an interrupted copy
    capsys.readouterr()
    again = prepare_problem(scenario).truth
    assert np.array_equal(first, again)
    notes = [line for line in capsys.readouterr().err.splitlines() if "damaged truth cache" in line]
    assert len(notes) == 2 and all("computing it again" in line for line in notes)


def test_another_orbit_is_another_entry_and_off_is_off(scenario, cache, monkeypatch):
    prepare_problem(scenario)
    prepare_problem(apply_overrides(scenario, {"spacecraft.1.elements.ta_deg": 10.0}))
    assert len(list(cache.glob("*.npz"))) == 3  # the unchanged spacecraft shared its entry
    monkeypatch.setenv("LIAISON_TRUTH_CACHE", "off")
    prepare_problem(apply_overrides(scenario, {"spacecraft.1.elements.ta_deg": 20.0}))
    assert len(list(cache.glob("*.npz"))) == 3
