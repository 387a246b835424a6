"""Issue 24's faults: silent wrong answers refused, no traceback or hang, bounded work. Each is one line on
stderr (`error: <file or option>: ...; allowed: ...`) with a documented exit code, and nothing written.

Most cases call the CLI in process (typer's CliRunner: the same `user_errors` mapping, no 1.5 s interpreter
start) or the loader directly where the loader's one-line message is the whole behaviour."""

import os
import socket
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from liaison_cli.errors import ScenarioError
from liaison_cli.scenario.loading import load_scenario
from tests.conftest import SCENARIOS, assert_one_line_error, edited_scenario
from tests.conftest import run_cli_in_process as cli


def refused(path, fragments):
    """Loading `path` raises the one-line ScenarioError naming it and every fragment."""
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(path)), message
    for fragment in fragments:
        assert fragment in message, (fragment, message)


# --- no silent wrong answers --------------------------------------------------------------------------


@pytest.mark.parametrize("edit,fragments", [
    (None, ["'dynamics' = 'ephemeris'", "CRTBP scenarios only", "allowed: dynamics: crtbp"]),
    (("    orbit: eml2_halo\n", "    orbit: eml2_halo\n    manoeuvre: {epoch_days: 0.5, delta_v_m_s: [0.1, 0, 0], "
      "apriori_sigma_m_s: 0.1}\n"), ["spacecraft[0].manoeuvre", "ballistic arcs"]),
])
def test_observability_refuses_what_it_cannot_honour(tmp_path, edit, fragments):
    """It maps partials with the CRTBP's STM along ballistic arcs: a dated scenario used to be analysed as
    the CRTBP, a manoeuvre would be left out."""
    path = SCENARIOS / "eph_eml1_eml2_dsn.yaml" if edit is None else edited_scenario(tmp_path, "smoke.yaml", *edit)
    proc = cli("observability", path, "--output", tmp_path / "o")
    assert_one_line_error(proc, path, fragments)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("old,new,fragments", [
    # a year after MSL's injection: the two-body hyperbola puts it ~10^8 km out (it reported "2/2 runs ok")
    ('epoch_utc: "2011-11-26T15:52:12.383"', 'epoch_utc: "2012-11-26T15:52:12.383"',
     ["ephemeris.epoch_utc", "'2012-11-26T15:52:12.383'", "8784.1 h after", "msl",
      "allowed: 2011-11-26T15:46:00 to 2011-11-26T18:46:00 UTC"]),
    ("departure: {mission: msl}",
     "departure: {c3_km2_s2: 10, dla_deg: 5, rla_deg: 120, time_from_periapsis_s: 86400}",
     ["spacecraft[1].departure.time_from_periapsis_s", "86400", "10800"]),
])
def test_a_departure_outside_the_models_window_is_refused(tmp_path, old, new, fragments):
    path = edited_scenario(tmp_path, "003/msl.yaml", old, new)
    assert_one_line_error(cli("run", path, "--output", tmp_path / "o"), path, fragments)
    assert not (tmp_path / "o").exists()


def test_the_departure_window_is_three_hours_after_injection(tmp_path):
    """The edges: 3 h after MSL's injection (15:46:00) is accepted, one second more is not."""
    load_scenario(edited_scenario(tmp_path, "003/msl.yaml", "15:52:12.383", "18:46:00"))
    refused(edited_scenario(tmp_path, "003/msl.yaml", "15:52:12.383", "18:46:01"), ["3.0003 h after"])


@pytest.mark.parametrize("source,old,new,fragments", [
    # the same pair twice counted one measurement twice: the reported error was halved
    ("smoke.yaml", "  - {receiver: EML2, transponder: Lunar}\n",
     "  - {receiver: EML2, transponder: Lunar}\n  - {receiver: EML2, transponder: Lunar}\n",
     ["links[1] repeats links[0]", "receiver EML2, transponder Lunar", "allowed: one link per set of ends"]),
    # a receiver pair with its receivers swapped measures the negated TDoA: the same information
    ("004/eml2_halo.yaml", "  - {receiver: GEO130W,",
     "  - {receiver: OwensValley, second_receiver: MaunaKea, transponder: TX, observables: [tdoa]}\n"
     "  - {receiver: GEO130W,", ["links[1] repeats links[0]", "second_receiver MaunaKea"]),
    ("ground_eml2.yaml", "ground_stations:\n", "ground_stations:\n  - {name: Goldstone, latitude_deg: 0, "
     "longitude_deg: 0}\n", ["participant names must be unique", "Goldstone"]),
    ("smoke.yaml", "  - name: Lunar\n", "  - name: EML2\n", ["participant names must be unique", "EML2"]),
])
def test_repeated_links_receivers_stations_and_spacecraft_are_refused(tmp_path, source, old, new, fragments):
    refused(edited_scenario(tmp_path, source, old, new), fragments)


def test_two_study_scenarios_with_one_stem_are_refused(tmp_path):
    """study003/004 label rows, metadata and figures by file stem: two files would merge into one label."""
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "msl.yaml").write_text((SCENARIOS / "003" / "msl.yaml").read_text())
    for command in ("study003", "study004"):
        proc = cli(command, tmp_path / "a" / "msl.yaml", tmp_path / "b" / "msl.yaml", "--output", tmp_path / "o")
        assert_one_line_error(proc, tmp_path / "b" / "msl.yaml", ["file stem 'msl'", str(tmp_path / "a" / "msl.yaml")])
    assert not (tmp_path / "o").exists()


def test_two_compared_scenarios_with_one_name_are_refused(tmp_path):
    """compare keys its table and metadata by `name`."""
    copy = tmp_path / "smoke_copy.yaml"
    copy.write_text((SCENARIOS / "smoke.yaml").read_text())
    proc = cli("compare", SCENARIOS / "smoke.yaml", copy, "--output", tmp_path / "o")
    assert_one_line_error(proc, copy, ["name 'smoke'", "distinct names"])
    assert not (tmp_path / "o").exists()


def test_stations_left_out_of_station_priority_follow_in_file_order(tmp_path):
    """A partial list used to exempt the unnamed stations from the one-observation rule. Now the priority
    is Madrid (named), then Goldstone and Canberra (file order): one station per epoch, the first that sees."""
    from liaison_cli.scenario.truth import apply_station_priority

    stations = "".join(f"  - {{name: {n}, latitude_deg: 35, longitude_deg: {lon}}}\n"
                       for n, lon in (("Goldstone", 0), ("Madrid", 120), ("Canberra", 240)))
    links = "".join(f"  - {{receiver: {n}, transponder: EML2}}\n" for n in ("Goldstone", "Madrid", "Canberra"))
    text = (SCENARIOS / "ground_eml2.yaml").read_text()
    start, end = text.index("ground_stations:"), text.index("measurement:")
    path = tmp_path / "three.yaml"
    path.write_text(text[:start] + f"ground_stations:\n{stations}station_priority: [Madrid]\nlinks:\n{links}"
                    + text[end:])
    scenario, _ = load_scenario(path)
    sees = np.array([[1, 1, 1, 0, 1, 0], [1, 0, 0, 1, 1, 0], [1, 1, 1, 1, 0, 1]], dtype=bool)  # per station
    kept = np.array(apply_station_priority(scenario, list(sees)))
    assert kept.sum(axis=0).tolist() == [1, 1, 1, 1, 1, 1]  # one observation wherever some station sees
    assert kept.argmax(axis=0).tolist() == [1, 0, 0, 1, 1, 2]  # Madrid, then Goldstone, then Canberra


# --- no traceback, no hang ----------------------------------------------------------------------------


OBSERVABILITY_PATHS = sorted(p for p in SCENARIOS.rglob("*.yaml") if "links" not in p.parts)


def test_the_observability_check_covers_every_shipped_scenario():
    assert len(OBSERVABILITY_PATHS) == 45


# The NRHO scenarios' truths take 4-6 s each (a perilune at 3,250 km halves the truth's step to ~1 s), the lunar
# ones' tens of seconds (the GRGM1200A field to degree 50-100): slow; the kinds they hold (stations, dual one-way
# links, a mesh, the lunar field) are covered by faster scenarios in the default suite.
@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow)
                                  if p.name.startswith("nrho_") or "lunar" in p.parent.name else p
                                  for p in OBSERVABILITY_PATHS],
                         ids=[str(p.relative_to(SCENARIOS)) for p in OBSERVABILITY_PATHS])
def test_observability_on_every_shipped_scenario_works_or_is_one_line(path):
    """It used to raise KeyError on stations, known spacecraft, departures. CRTBP scenarios get their inputs
    (known participants as given trajectories); dated ones are refused in one line."""
    from liaison_cli.campaign.studies.observability_study import check_supported, known_inputs, scenario_inputs

    scenario, _ = load_scenario(path)
    if scenario.dynamics == "ephemeris":
        with pytest.raises(ScenarioError, match="observability supports CRTBP scenarios only"):
            check_supported(scenario, str(path))
        return
    check_supported(scenario, str(path))
    names, states0, times_s, links = scenario_inputs(scenario)
    known, visible = known_inputs(scenario, times_s)
    assert states0.shape == (len(names), 6) and visible.shape == (len(links), len(times_s))


def test_observability_of_a_ground_station_scenario_counts_only_visible_epochs(tmp_path):
    """ground_eml2: the station's link adds information only above its 10 deg mask."""
    import pandas as pd

    proc = cli("observability", SCENARIOS / "ground_eml2.yaml", "--no-taylor", "--output", tmp_path / "o")
    assert proc.returncode == 0, proc.stderr
    table = pd.read_parquet(tmp_path / "o" / "effectiveness.parquet")
    rng = table[table.observable == "range"].position_effectiveness.to_numpy()[1:]
    assert 0.2 < np.mean(rng == 0.0) < 0.8 and np.all(rng >= 0.0)  # hidden part of each day: no information


def test_a_damaged_family_cache_is_rebuilt(tmp_path, monkeypatch, capsys):
    """A truncated .npz (BadZipFile) used to break every command needing the family."""
    from liaison_cli.orbits.family_store import family_path, load_or_generate

    monkeypatch.setenv("LIAISON_ORBIT_CACHE_DIR", str(tmp_path))
    good, cached = load_or_generate("l2_halo_south", 3)
    path = family_path("l2_halo_south", 3)
    assert not cached and path.exists()
    path.write_bytes(path.read_bytes()[:200])
    rebuilt, cached = load_or_generate("l2_halo_south", 3)
    assert not cached and np.array_equal(rebuilt.x0, good.x0)
    note = capsys.readouterr().err.strip().splitlines()
    assert len(note) == 1 and str(path) in note[0] and "damaged" in note[0] and "--regenerate" in note[0]
    assert load_or_generate("l2_halo_south", 3)[1]  # the rebuilt file is read back


def _loopback_server(kind: str) -> int:
    """A server on 127.0.0.1 that is not dask: 'silent' accepts and says nothing; 'http' answers HTTP."""
    if kind == "http":
        import http.server

        class Quiet(http.server.BaseHTTPRequestHandler):
            def log_message(self, *args):  # keep the test's stderr clean
                pass

        server = http.server.HTTPServer(("127.0.0.1", 0), Quiet)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        return server.server_address[1]
    listener = socket.create_server(("127.0.0.1", 0))
    held = []
    threading.Thread(target=lambda: [held.append(listener.accept()) for _ in range(16)], daemon=True).start()
    return listener.getsockname()[1]


@pytest.mark.parametrize("kind", ["silent", "http"])
def test_a_scheduler_that_is_not_dask_fails_within_the_timeout(tmp_path, kind):
    """It used to hang forever (distributed's handshake read has no timeout) holding the sweep lock."""
    pytest.importorskip("distributed")
    address = f"tcp://127.0.0.1:{_loopback_server(kind)}"
    start = time.monotonic()
    proc = cli("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100", "--runs", "1", "--backend", "dask",
               "--scheduler", address, "--scheduler-timeout", "1", "--quiet", "--output", tmp_path / "o")
    assert time.monotonic() - start < 5.0
    assert_one_line_error(proc, address, ["cannot connect", "within 1 s", "--scheduler-timeout"], code=3)
    assert not (tmp_path / "o").exists() and not (tmp_path / ".o.lock").exists()  # refused before the lock


def test_a_malformed_scheduler_address_is_one_line_exit_2(tmp_path):
    pytest.importorskip("distributed")
    proc = cli("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100", "--backend", "dask",
               "--scheduler", "tcp://127.0.0.1:notaport", "--output", tmp_path / "o")
    assert_one_line_error(proc, "tcp://127.0.0.1:notaport", ["not a scheduler address", "allowed: [tcp|tls]://HOST:PORT"])


@pytest.mark.parametrize("state,fragments", [
    ("[0, 0, 0, 0, 0, 0]", ["0.0 km from the Earth's centre", "allowed: a geocentric position above 6378.137 km"]),
    ("[3000, 0, 4000, 0, 7, 0]", ["5000.0 km from the Earth's centre", "inside the Earth"]),
])
def test_an_icrf_state_inside_the_earth_is_refused(tmp_path, state, fragments):
    path = edited_scenario(tmp_path, "004/low_energy_transfer.yaml",
                           "[20596.04161, 201898.7866, 87521.69929, -0.1714039415, 1.559312361, 0.6759113513]", state)
    refused(path, ["spacecraft[0]", *fragments])


# --- bounded work -------------------------------------------------------------------------------------


@pytest.mark.parametrize("args,option", [
    (["study003", "--runs", "1000001"], "--runs 1000001"),
    (["study004", "--runs", "1000001"], "--runs 1000001"),
    (["errors", SCENARIOS / "smoke.yaml", "--check-runs", "1000001"], "--check-runs 1000001"),
])
def test_every_command_that_runs_filters_has_the_runs_cap(tmp_path, args, option):
    proc = cli(*args, "--output", tmp_path / "o")
    assert_one_line_error(proc, option, ["at most 1,000,000 runs"])
    assert not (tmp_path / "o").exists()


def test_too_many_epochs_per_run_are_refused_before_any_work(tmp_path):
    """0.001 s over 10 days (~10^9 epochs) ran into a MemoryError after 42 s."""
    path = edited_scenario(tmp_path, "eml2_lunar.yaml", "interval_s: 187.5", "interval_s: 0.001")
    start = time.monotonic()
    proc = cli("run", path, "--output", tmp_path / "o")
    assert time.monotonic() - start < 2.0
    assert_one_line_error(proc, path, ["measurement.interval_s = 0.001", "duration_days = 10",
                                       "864,000,001 epochs", "allowed: at most 500,000"])
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("grid,runs,fragments", [
    # two 5,000-value axes grew to 1.4 GB while planning
    ([f"--grid=noise.sigma_m={','.join(str(v) for v in range(1, 5001))}",
      f"--grid=filter.process_noise_accel_m_s2={','.join(f'{v}e-9' for v in range(1, 5001))}"], "1",
     ["25,000,000 grid points", "allowed: at most 10,000"]),
    (["--sigma", "50:700"], "100000", ["14 grid points x 100,000 runs", "allowed: at most 1,000,000"]),
])
def test_a_sweep_grid_above_the_cap_is_refused_before_planning(tmp_path, grid, runs, fragments):
    start = time.monotonic()
    proc = cli("sweep", SCENARIOS / "smoke.yaml", *grid, "--runs", runs, "--output", tmp_path / "o")
    assert time.monotonic() - start < 2.0
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert all(f in proc.stderr for f in fragments), proc.stderr
    assert not (tmp_path / "o").exists()


def test_a_scenario_that_is_not_a_small_regular_file_is_refused_unread(tmp_path):
    """A FIFO would block the reader, /dev/zero never ends: both refused from their stat, before a read."""
    fifo, big = tmp_path / "fifo.yaml", tmp_path / "big.yaml"
    os.mkfifo(fifo)
    big.write_text("# padding\n" * 120_000)  # 1.2 MB of comments: valid YAML, too large
    cases = [(fifo, "not a regular file"), (Path("/dev/zero"), "not a regular file"),
             (tmp_path, "a directory"), (big, "1,200,000 bytes; allowed: a YAML file of at most 1,048,576 bytes")]
    for path, fragment in cases:
        outcome = []
        worker = threading.Thread(target=lambda: outcome.append(cli("run", path, "--output", tmp_path / "o")),
                                  daemon=True)
        worker.start()
        worker.join(10.0)
        assert outcome, f"{path}: the loader blocked"
        assert_one_line_error(outcome[0], path, [fragment])
    assert not (tmp_path / "o").exists()


def test_a_failure_before_any_connection_is_not_called_an_answer(monkeypatch):
    """Issue 47: an error raised before a connection was made read 'answered, but not as a dask scheduler' when
    nothing had answered; it is 'cannot connect' with the cause."""
    pytest.importorskip("distributed")
    import distributed.comm

    from liaison_cli.campaign.engine.backends import probe_scheduler
    from liaison_cli.errors import LiaisonError

    async def refuse(address, timeout=None, **kwargs):
        raise ValueError("no route to the named host")

    monkeypatch.setattr(distributed.comm, "connect", refuse)
    with pytest.raises(LiaisonError) as refused:
        probe_scheduler("tcp://127.0.0.1:8786", 1.0)
    assert "cannot connect (ValueError: no route to the named host)" in str(refused.value)
    assert "answered" not in str(refused.value)
