"""The disk cache of orbits corrected into the dated model: the same nodes as a fresh correction, keyed by
every input, a damaged file rebuilt with a note, no temporary files left behind."""

import dataclasses
from datetime import datetime

import numpy as np
import pytest

from liaison_cli.dynamics.ephemeris import GM_KM3_S2, load_window
from liaison_cli.dynamics.ephemeris_dynamics import dated_terms, moon_harmonics_term
from liaison_cli.dynamics.lunar_gravity import lunar_field
from liaison_cli.dynamics.timescales import utc_to_tdb_seconds
from liaison_cli.orbits import corrected_store
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.orbits.ephemeris_correction import ForceModel, corrected_in_stages

BODIES = np.array([301, 10, 1, 2, 4, 5, 6, 7, 8, 9])
SPAN_S, SPACING_S = 3 * 86400.0, 86400.0  # three segments: a correction of a few seconds


@pytest.fixture(scope="module")
def setting():
    t0 = utc_to_tdb_seconds(datetime(2022, 11, 1))
    window = load_window(t0, t0 + 4 * 86400)
    forces = ForceModel(window, BODIES, np.array([GM_KM3_S2[int(b)] for b in BODIES]), GM_KM3_S2[399], 0.015)
    return np.array(CATALOG["eml1_halo"].state()), t0, forces


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("LIAISON_CACHE_DIR", str(tmp_path))
    return tmp_path / "dated-orbits"


def test_second_call_reads_the_same_nodes_from_disk(setting, cache):
    state, t0, forces = setting
    first, cached_first = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    second, cached_second = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    assert (cached_first, cached_second) == (False, True) and first.converged
    fresh = corrected_in_stages(state, t0, SPAN_S, SPACING_S, forces)
    for orbit in (first, second):
        assert np.array_equal(orbit.nodes, fresh.nodes) and np.array_equal(orbit.node_times_s, fresh.node_times_s)
        assert orbit.position_defects_km == fresh.position_defects_km and orbit.iterations == fresh.iterations
        assert orbit.velocity_defects_km_s == fresh.velocity_defects_km_s and orbit.converged
    assert [p.suffix for p in cache.iterdir()] == [".npz"]  # one file, no temporary leftovers


def test_every_input_is_in_the_key(setting):
    state, t0, forces = setting
    args = (state, t0, SPAN_S, SPACING_S, forces, 200, 20)
    key = corrected_store.correction_key(*args)
    shifted_window = dataclasses.replace(forces.window, coeffs=forces.window.coeffs * (1 + 1e-15))
    variants = [
        (state + np.r_[1e-12, 0, 0, 0, 0, 0], *args[1:]),
        (state, t0 + 1.0, *args[2:]),
        (*args[:2], 2 * SPAN_S, *args[3:]),
        (*args[:3], SPACING_S / 2, *args[4:]),
        (*args[:4], dataclasses.replace(forces, cr_am=0.02), *args[5:]),
        (*args[:4], dataclasses.replace(forces, bodies=BODIES[:2], gms=forces.gms[:2]), *args[5:]),
        (*args[:4], dataclasses.replace(forces, window=shifted_window), *args[5:]),
        (*args[:4], dataclasses.replace(forces, terms=dated_terms(moon_harmonics_term(lunar_field(4)))), *args[5:]),
        (*args[:5], 100, 20),
        (*args[:6], 10),
        (*args, CATALOG["eml1_halo"].period_tu),  # patch points taken within one period
    ]
    keys = {corrected_store.correction_key(*variant) for variant in variants}
    assert key not in keys and len(keys) == len(variants)


def test_the_code_of_the_corrector_is_in_the_key(setting, monkeypatch):
    state, t0, forces = setting
    key = corrected_store.correction_key(state, t0, SPAN_S, SPACING_S, forces, 200, 20)
    monkeypatch.setattr(corrected_store, "core_source_hash", lambda packages: "another-corrector")
    assert corrected_store.correction_key(state, t0, SPAN_S, SPACING_S, forces, 200, 20) != key


@pytest.mark.parametrize("damage", [b"", b"not a zip file", "truncated"])
def test_a_damaged_file_is_rebuilt_with_a_note(setting, cache, capsys, damage):
    state, t0, forces = setting
    good, _ = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    (path,) = cache.iterdir()
    path.write_bytes(path.read_bytes()[:100] if damage == "truncated" else damage)
    capsys.readouterr()
    rebuilt, from_cache = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    note = capsys.readouterr().err
    assert not from_cache and str(path) in note and "damaged corrected-orbit cache" in note
    assert np.array_equal(rebuilt.nodes, good.nodes)
    assert corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)[1]  # the rebuilt file reads


def test_a_file_with_nodes_that_do_not_fit_their_times_is_rebuilt(setting, cache, capsys):
    state, t0, forces = setting
    good, _ = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    (path,) = cache.iterdir()
    fields = {name: np.asarray(getattr(good, name)) for name in corrected_store.FIELDS}
    np.savez(path, **{**fields, "nodes": good.nodes[:-1]})
    rebuilt, from_cache = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    assert not from_cache and "malformed arrays" in capsys.readouterr().err
    assert np.array_equal(rebuilt.nodes, good.nodes)


def test_an_orbit_corrected_in_stages_is_read_back_from_disk(setting, cache, monkeypatch):
    """Stages keep one defect entry per Jacobian, so the file passes its intact check: a staged orbit was
    rebuilt at every read (a 'damaged cache' note each time) while its defects counted the last stage only."""
    from liaison_cli.orbits import ephemeris_correction

    monkeypatch.setattr(ephemeris_correction, "STAGE_DAYS", 1.0)  # three one-day stages over the 3 d
    state, t0, forces = setting
    first, cached_first = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    second, cached_second = corrected_store.corrected_orbit(state, t0, SPAN_S, SPACING_S, forces)
    assert (cached_first, cached_second) == (False, True) and first.converged
    assert first.iterations == len(first.position_defects_km) > 3  # every stage's Jacobians
    assert np.array_equal(first.nodes, second.nodes)
