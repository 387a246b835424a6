"""Periodic-orbit families: the corrector against Table 1, the 9:2 NRHO, closure, continuity, the cache."""

import numpy as np
import pytest

from liaison_cli.dynamics.constants import MU
from liaison_cli.dynamics.integrators.dop853 import dop853_states
from liaison_cli.orbits.catalog import CATALOG
from liaison_cli.orbits.families import FAMILIES, FamilyError, member_by_period
from liaison_cli.orbits.periodic import correct, lagrange_point_x
from tests.conftest import SCENARIOS, run_cli_in_process

SYNODIC_MONTH_DAYS = 29.530589


@pytest.fixture(scope="module")
def families():
    """Every family as `liaison run` reads it: the shipped catalogue's table (orbits.family_catalogue)."""
    from liaison_cli.orbits import family_store

    tables = {name: family_store.load_or_generate(name)[0] for name in sorted(FAMILIES)}
    return tables, family_store.family_tables_dir()


def test_another_count_fills_an_empty_cache_and_is_then_read(tmp_path, monkeypatch):
    """A count other than the catalogue's is generated into the user cache (the first call writes the file,
    the second reads it back bit for bit); the mirrored class is made from the base class, not continued
    again; the default count is read from the catalogue and writes nothing."""
    from liaison_cli.orbits import family_store

    monkeypatch.setenv("LIAISON_ORBIT_CACHE_DIR", str(tmp_path))
    assert family_store.load_or_generate("l2_halo_south")[1] and family_store.cached_families() == []
    made = {name: family_store.load_or_generate(name, 7) for name in ("l2_halo_south", "l2_halo_north")}
    assert not any(cached for _, cached in made.values())
    assert len(family_store.cached_families()) == 2
    for name, (table, _) in made.items():
        again, cached = family_store.load_or_generate(name, 7)
        assert cached and np.array_equal(again.x0, table.x0) and np.array_equal(again.vz0, table.vz0)
        assert again.period_days[0] == pytest.approx(8.5, abs=1e-9) and again.period_days[-1] == pytest.approx(14.8)


@pytest.mark.parametrize("name,fixed_x0", [("eml2_halo", 1.1785868), ("eml1_halo", 0.8614062)])
def test_corrector_reproduces_table1_from_a_nearby_guess(name, fixed_x0):
    table1 = CATALOG[name].state()
    guess = np.array([fixed_x0, table1[2] * 1.02, table1[4] + 5e-4, CATALOG[name].period_tu / 2 * 1.01])
    X, iterations = correct(guess, planar=False, fixed=0)
    assert iterations <= 8
    # Table 1 gives 7 significant digits.
    assert X[1] == pytest.approx(table1[2], abs=2e-7)
    assert X[2] == pytest.approx(table1[4], abs=2e-7)


def test_lagrange_points():
    for point, expected in ((1, 0.83691513), (2, 1.15568217)):
        assert lagrange_point_x(point, MU) == pytest.approx(expected, abs=1e-6)


def test_every_member_recloses_and_families_are_continuous(families):
    tables, _ = families
    for name, frame in tables.items():
        assert len(frame) == 30, name
        assert frame.closure_lu.max() < 1e-9, name
        for row in frame.itertuples():  # independent check with the truth propagator
            state0 = np.array([row.x0, row.y0, row.z0, row.vx0, row.vy0, row.vz0])
            end = dop853_states(state0, np.array([0.0, row.period_tu]), MU)[-1]
            assert np.max(np.abs(end - state0)) < 1e-9, (name, row.member)
        jacobi = np.asarray(frame.jacobi)
        span = jacobi.max() - jacobi.min()
        # no jump to another family (0.2: the DRO table starts at 1 d, where equal period steps change C by 0.15)
        assert np.max(np.abs(np.diff(jacobi))) < min(0.2, 0.35 * span), name
        assert np.all(np.abs(np.diff(frame.x0)) < 0.05), name


def test_north_is_the_mirror_of_south(families):
    tables, _ = families
    for kind in ("l1_halo", "l2_halo", "l2_nrho"):
        south, north = tables[f"{kind}_south"], tables[f"{kind}_north"]
        assert (south.z0 < 0).all() and (north.z0 > 0).all()
        assert np.allclose(south.z0, -north.z0) and np.allclose(south.period_days, north.period_days)


def test_table1_orbits_lie_on_the_southern_halo_families(families):
    tables, _ = families
    for name, family in (("eml2_halo", "l2_halo_south"), ("eml1_halo", "l1_halo_south")):
        days = CATALOG[name].period_tu * 375190.26 / 86400.0
        frame = tables[family]
        assert frame.period_days.min() < days < frame.period_days.max() + 0.01


def test_nine_two_nrho(families):
    tables, _ = families
    from liaison_cli.orbits.family_store import from_table as from_frame

    period = 2.0 * SYNODIC_MONTH_DAYS / 9.0  # 9 revolutions in 2 synodic months: 6.5624 d
    orbit = member_by_period("l2_nrho_south", from_frame(tables["l2_nrho_south"]), period)
    assert orbit.period_tu * 375190.26 / 86400.0 == pytest.approx(period, abs=1e-6)
    assert 3000 < orbit.perilune_km < 3700 and 68000 < orbit.apolune_km < 73000  # published: ~3,200 / ~71,000 km
    assert orbit.stability_index < 2.0  # NRHOs are nearly stable
    assert orbit.closure_lu < 1e-9


def test_period_outside_family_names_the_range(families):
    tables, _ = families
    from liaison_cli.orbits.family_store import from_table as from_frame

    with pytest.raises(FamilyError, match=r"valid 6\.200 to 8\.000 days"):
        member_by_period("l2_nrho_south", from_frame(tables["l2_nrho_south"]), 9.5)


def _family_scenario(tmp_path, orbit_lines):
    text = (SCENARIOS / "smoke.yaml").read_text().replace("    orbit: eml2_halo\n", orbit_lines)
    path = tmp_path / "family.yaml"
    path.write_text(text)
    return path


def test_scenario_names_an_orbit_by_family_and_period(families, tmp_path):
    path = _family_scenario(tmp_path, "    orbit: l2_nrho_south\n    period_days: 6.5624\n")
    proc = run_cli_in_process("run", path, "--output", tmp_path / "o", "--jobs", "1", "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "2/2 runs ok" in proc.stdout
    bad = _family_scenario(tmp_path, "    orbit: l2_nrho_south\n    period_days: 12\n")
    proc = run_cli_in_process("run", bad, "--output", tmp_path / "b")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    line = proc.stderr.strip()
    assert "\n" not in line and "spacecraft[0].period_days" in line and "= 12" in line and "valid 6.200" in line


def test_unknown_family_is_one_line(tmp_path):
    proc = run_cli_in_process("orbits", "generate", "l3_halo_south")
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "unknown orbit family 'l3_halo_south'" in proc.stderr and "l2_nrho_south" in proc.stderr
    path = _family_scenario(tmp_path, "    orbit: l3_halo\n    period_days: 10\n")
    proc = run_cli_in_process("run", path, "--output", tmp_path / "o")
    assert proc.returncode == 2 and "l2_halo_south" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_member_by_amplitude(families):
    tables, _ = families
    from liaison_cli.orbits.family_store import from_table as from_frame
    from liaison_cli.orbits.families import amplitude_km, member_by_amplitude

    for name, target in (("l2_halo_south", 30000.0), ("l1_lyapunov", 40000.0)):
        frame = tables[name]
        assert frame.amplitude_km.min() < target < frame.amplitude_km.max()
        orbit = member_by_amplitude(name, from_frame(frame), target)
        assert amplitude_km(orbit, FAMILIES[name].planar) == pytest.approx(target, abs=1.0)
        assert orbit.closure_lu < 1e-9
    with pytest.raises(FamilyError, match=r"amplitude_km = 1e\+06 is outside family 'dro': valid \d+ to \d+ km"):
        member_by_amplitude("dro", from_frame(tables["dro"]), 1e6)


def test_validate_and_run_refuse_a_member_past_the_stated_end_in_one_line(tmp_path):
    """l2_lyapunov ends at 28 d by rule (the walk itself stopped at 30.00 d or 30.21 d by BLAS kernel, and a
    30.1 d member validated, then crashed the run): validate and run refuse it alike, exit 2, one line."""
    path = _family_scenario(tmp_path, "    orbit: l2_lyapunov\n    period_days: 30.1\n")
    for command in (("validate", path), ("run", path, "--output", tmp_path / "o")):
        proc = run_cli_in_process(*command)
        assert proc.returncode == 2 and "Traceback" not in proc.stderr, command
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "period_days" in lines[0] and "valid 15.000 to 28.000 days" in lines[0], command
