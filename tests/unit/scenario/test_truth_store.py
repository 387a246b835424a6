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


def test_the_folder_is_bounded_by_bytes_oldest_first(cache, monkeypatch):
    """LIAISON_TRUTH_CACHE_MB bounds the folder: an eviction check (every EVICT_EVERY stores of a process) deletes
    the oldest entries until the rest fit; a bad value falls back to the default."""
    import os

    from liaison_cli.scenario import truth_store

    monkeypatch.setattr(truth_store, "_stores", 0)
    states = np.zeros((2000, 6))  # 96 kB of floats
    for i in range(6):
        truth_store.store_truth(f"k{i}", states)
        path = truth_store._path(f"k{i}")
        os.utime(path, (1000.0 + i, 1000.0 + i))  # k0 oldest
    size = truth_store._path("k0").stat().st_size
    monkeypatch.setenv("LIAISON_TRUTH_CACHE_MB", str(3.5 * size / 1e6))
    truth_store._evict(truth_store.budget_bytes())
    assert sorted(p.name for p in cache.glob("*.npz")) == sorted(truth_store._path(f"k{i}").name for i in (3, 4, 5))
    assert truth_store.load_truth("k5", 2000) is not None and truth_store.load_truth("k0", 2000) is None
    monkeypatch.setenv("LIAISON_TRUTH_CACHE_MB", "lots")
    assert truth_store.budget_bytes() == truth_store.MAX_MEGABYTES * 1_000_000


def test_storing_evicts_every_few_stores_and_a_vanished_entry_is_a_quiet_miss(cache, monkeypatch, capsys):
    """store_truth itself checks the bound (every EVICT_EVERY stores of a process); an infinite or bad budget is
    the default; a file another process evicted between the look and the read is a miss without a note."""
    from liaison_cli.scenario import truth_store

    monkeypatch.setattr(truth_store, "_stores", 0)
    monkeypatch.setattr(truth_store, "EVICT_EVERY", 2)
    states = np.zeros((2000, 6))
    truth_store.store_truth("probe", states)
    size = truth_store._path("probe").stat().st_size
    monkeypatch.setenv("LIAISON_TRUTH_CACHE_MB", str(2.5 * size / 1e6))
    for i in range(6):
        truth_store.store_truth(f"k{i}", states)
    assert len(list(cache.glob("*.npz"))) <= 3  # bounded by the stores' own checks, one store of slack
    monkeypatch.setenv("LIAISON_TRUTH_CACHE_MB", "inf")
    assert truth_store.budget_bytes() == truth_store.MAX_MEGABYTES * 1_000_000
    path = truth_store._path("k5")
    real_is_file = type(path).is_file
    monkeypatch.setattr(type(path), "is_file", lambda self: True if self == path else real_is_file(self))
    path.unlink(missing_ok=True)
    capsys.readouterr()
    assert truth_store.load_truth("k5", 2000) is None and "damaged" not in capsys.readouterr().err
