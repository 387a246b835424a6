"""Durability (issue 24): result swaps that never leave NAME missing, stale staging folders cleaned, the
sweep lock on the resolved path, the manifest format rule and retried errors, the vendored DOP853 tableau."""

import subprocess
import sys

import numpy as np
import pytest


# --- the DOP853 tableau -----------------------------------------------------------------------------------


def test_the_vendored_tableau_equals_scipys_exactly():
    import importlib

    try:
        scipy_tableau = importlib.import_module("scipy.integrate._ivp.dop853_coefficients")
    except ImportError:
        pytest.skip("scipy moved its private DOP853 coefficients; the vendored copy stands on its own")
    from liaison_cli.dynamics.integrators.rk8 import RK8_A, RK8_B, RK8_C

    stages = scipy_tableau.N_STAGES
    assert RK8_A.shape == (stages, stages) and RK8_B.shape == RK8_C.shape == (stages,)
    # Bit for bit, not allclose: the compiled truth and the filters must not move by a single ulp.
    assert np.array_equal(RK8_A, scipy_tableau.A[:stages, :stages])
    assert np.array_equal(RK8_B, scipy_tableau.B)
    assert np.array_equal(RK8_C, scipy_tableau.C[:stages])
    from liaison_cli.dynamics.integrators import dop853, dop853_tableau  # the adaptive one's rows too

    for ours, theirs in ((dop853.A, scipy_tableau.A[:stages, :stages]), (dop853.B, scipy_tableau.B),
                         (dop853.E5, scipy_tableau.E5), (dop853.E3, scipy_tableau.E3),
                         (dop853.A_EXTRA, scipy_tableau.A[stages + 1:]), (dop853.D, scipy_tableau.D),
                         (np.array(dop853_tableau.C_EXTRA), scipy_tableau.C[stages + 1:])):
        assert ours.shape == theirs.shape and np.array_equal(ours, theirs)


def test_the_integrator_imports_without_scipy():
    code = ("import sys\nsys.modules['scipy'] = None  # any scipy import now fails\n"
            "from liaison_cli.dynamics.integrators.rk8 import RK8_A\n"
            "from liaison_cli.dynamics.integrators.dop853 import dop853_states\nprint(RK8_A.shape)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "(12, 12)", out.stderr


def test_the_tableau_is_covered_by_the_compiled_cache_key(monkeypatch):
    """numba's cache is keyed on core_source_hash: an edited tableau must give a new key (stale machine code
    with the old coefficients frozen in would otherwise be loaded)."""
    from pathlib import Path

    from liaison_cli import core_source_hash

    before = core_source_hash()
    real_read = Path.read_bytes
    edit = b"\nA_NEW_COEFFICIENT = 0.25\n"
    monkeypatch.setattr(Path, "read_bytes", lambda self: real_read(self) + (edit if self.name == "dop853_tableau.py"
                                                                            else b""))
    assert core_source_hash() != before


# --- result swaps and leftovers ---------------------------------------------------------------------------

# A writer in its own process, killed (SIGKILL: no cleanup runs) at a chosen moment of staged_output.
WRITER = r"""
import os, signal, sys
from pathlib import Path
from liaison_cli import storage

moment, out = sys.argv[1], Path(sys.argv[2])
die = lambda *args, **kwargs: os.kill(os.getpid(), signal.SIGKILL)
if moment == "between-renames":  # the old result is aside, the stage not yet in: NAME is missing
    storage.swap._renameat2 = lambda: None
    real_replace = os.replace
    os.replace = lambda src, dst: die() if Path(src).name.startswith(f".{out.name}.partial-") \
        else real_replace(src, dst)
if moment == "after-exchange":  # the names are exchanged; the old result not yet removed
    storage.swap.shutil.rmtree = die
with storage.staged_output(out, overwrite=True) as stage:
    (stage / "data.txt").write_text("new")
    if moment == "mid-write":
        die()
    if moment == "wait":
        print(stage, flush=True)
        sys.stdin.readline()
"""


def _kill_writer_at(moment, out):
    proc = subprocess.run([sys.executable, "-c", WRITER, moment, str(out)], capture_output=True, text=True)
    assert proc.returncode == -9, proc.stderr  # it was killed where intended, not before


def _old_result(out):
    from liaison_cli.storage import staged_output

    with staged_output(out, overwrite=False) as stage:
        (stage / "data.txt").write_text("old")


def _hidden(parent):
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def _dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()  # reaped: the pid names no process
    return proc.pid


@pytest.fixture
def exchange_supported(tmp_path):
    from liaison_cli.storage.swap import _exchange

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    if not _exchange(a, b):
        pytest.skip("this kernel or file system cannot exchange names (renameat2); the fallback is tested")
    a.rmdir(), b.rmdir()


def test_a_kill_right_after_the_exchange_leaves_the_new_result_and_the_old_is_cleaned_next(
        tmp_path, exchange_supported, capsys):
    from liaison_cli.storage import recover_output

    out = tmp_path / "out"
    _old_result(out)
    _kill_writer_at("after-exchange", out)
    assert (out / "data.txt").read_text() == "new" and (out / ".liaison-result").exists()
    # The killed writer held the folder's writer lock across the swap: its lock file stays until the next writer.
    [leftover] = [name for name in _hidden(tmp_path) if name != ".out.lock"]
    assert leftover.startswith(".out.partial-") and (tmp_path / leftover / "data.txt").read_text() == "old"
    recover_output(out)  # what the next command writing `out` does first
    assert _hidden(tmp_path) == [] and (out / "data.txt").read_text() == "new"
    assert capsys.readouterr().err == ""  # a plain cleanup says nothing


def test_a_kill_between_the_two_renames_is_repaired_by_the_next_command(tmp_path):
    from tests.conftest import SCENARIOS, run_cli_in_process

    out = tmp_path / "out"
    _old_result(out)
    _kill_writer_at("between-renames", out)
    assert not out.exists()  # the fault being repaired: NAME missing, the old result hidden
    aside = [name for name in _hidden(tmp_path) if name.startswith(".out.old-")]
    assert len(aside) == 1 and (tmp_path / aside[0] / "out" / "data.txt").read_text() == "old"
    proc = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--output", out)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    note, refusal = proc.stderr.strip().splitlines()
    assert note.startswith(f"note: {out}: restored the previous result") and "already exists" in refusal
    assert (out / "data.txt").read_text() == "old" and (out / ".liaison-result").exists()
    assert _hidden(tmp_path) == []  # the set-aside folder and the killed run's stage are both gone


@pytest.mark.parametrize("failing", ["set-aside", "stage-in"])
def test_an_io_error_in_either_rename_keeps_the_old_result_in_place(tmp_path, monkeypatch, failing):
    import errno
    import os

    from liaison_cli import storage

    out = tmp_path / "out"
    _old_result(out)
    monkeypatch.setattr(storage.swap, "_renameat2", lambda: None)
    real_replace = os.replace
    source = ".out.partial-" if failing == "stage-in" else "out"

    def failing_rename(src, dst):
        if os.path.basename(src).startswith(source):
            raise OSError(errno.EIO, os.strerror(errno.EIO), str(dst))
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", failing_rename)
    with pytest.raises(OSError, match="Input/output error"):
        with storage.staged_output(out, overwrite=True) as stage:
            (stage / "data.txt").write_text("new")
    assert (out / "data.txt").read_text() == "old" and _hidden(tmp_path) == []  # put back at once


def test_an_io_error_in_the_exchange_keeps_the_old_result(tmp_path, monkeypatch):
    import errno
    import os

    from liaison_cli import storage

    def failing_exchange(first, second):
        raise OSError(errno.EIO, os.strerror(errno.EIO), str(second))

    out = tmp_path / "out"
    _old_result(out)
    monkeypatch.setattr(storage.swap, "_exchange", failing_exchange)
    with pytest.raises(OSError, match="Input/output error"):
        with storage.staged_output(out, overwrite=True) as stage:
            (stage / "data.txt").write_text("new")
    assert (out / "data.txt").read_text() == "old" and _hidden(tmp_path) == []


@pytest.mark.parametrize("fallback", [False, True])
def test_a_replacement_leaves_only_the_new_result(tmp_path, monkeypatch, fallback):
    from liaison_cli import storage

    if fallback:
        monkeypatch.setattr(storage.swap, "_renameat2", lambda: None)
    out = tmp_path / "out"
    _old_result(out)
    with storage.staged_output(out, overwrite=True) as stage:
        (stage / "data.txt").write_text("new")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert sorted(p.name for p in out.iterdir()) == [".liaison-result", "data.txt"]
    assert (out / "data.txt").read_text() == "new"


def test_stale_staging_folders_are_cleaned_and_nothing_else(tmp_path):
    import fcntl
    import os

    from liaison_cli.storage import recover_output

    out = tmp_path / "out"
    _kill_writer_at("mid-write", out)  # a killed run: its stage, with our marker and a file
    [killed] = _hidden(tmp_path)
    dead = _dead_pid()
    keep = {
        f".out.partial-{dead}-notours1": "a file",  # not ours: no marker, not empty
        f".out.old-{dead}-notours2": "a file",  # set aside by something else
        f".other.partial-{dead}-abcdefgh": None,  # another output's
        f".out.partial-{dead}-locked12": None,  # ours, but in use (its flock is held below)
        ".out.partial-notes": None,  # not a name we make
    }
    for name, content in keep.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / ".liaison-result").write_text("written by liaison\n")
        if content:
            (tmp_path / name / ".liaison-result").unlink()
            (tmp_path / name / "mine.txt").write_text(content)
    (tmp_path / f".out.partial-{dead}-emptyxx1").mkdir()  # empty: removed
    (tmp_path / f".out.old-{dead}-emptyxx2").mkdir()
    (tmp_path / ".out.partial-12345678").write_text("a file with a staging-like name")
    keep[".out.partial-12345678"] = None
    fd = os.open(tmp_path / f".out.partial-{dead}-locked12", os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        recover_output(out)
    finally:
        os.close(fd)
    assert _hidden(tmp_path) == sorted(keep)  # the killed stage and the empty ones are gone, nothing else
    assert not (tmp_path / killed).exists() and not out.exists()


def test_a_stage_in_use_by_a_live_writer_is_left_alone(tmp_path):
    from liaison_cli.storage import recover_output

    out = tmp_path / "out"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, "wait", str(out)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        stage = writer.stdout.readline().strip()
        assert stage, "the writer did not start"
        recover_output(out)  # another command writing the same output starts now
        assert (tmp_path / stage.rsplit("/", 1)[1] / "data.txt").read_text() == "new"
    finally:
        writer.communicate("go\n", timeout=30)
    assert writer.returncode == 0 and (out / "data.txt").read_text() == "new" and _hidden(tmp_path) == []


# --- sweeps: the lock, the manifest format, retried errors ------------------------------------------------


def test_the_sweep_lock_holds_the_folder_whatever_the_path_spelling(tmp_path):
    from liaison_cli.campaign.sweep.manifest import sweep_lock
    from liaison_cli.campaign.sweep.plan import SweepError

    real = tmp_path / "results" / "sweep"
    real.mkdir(parents=True)
    (tmp_path / "link").symlink_to(real)
    (tmp_path / "other").mkdir()
    with sweep_lock(real):
        for spelling in (tmp_path / "link", tmp_path / "other" / ".." / "results" / "sweep"):
            with pytest.raises(SweepError, match="another liaison sweep"):
                with sweep_lock(spelling):
                    pass
    with sweep_lock(tmp_path / "link"):  # free again, through the link too
        pass


def _written_sweep(tmp_path, runs=2):
    import json

    from liaison_cli.campaign.sweep.run import run_sweep
    from tests.unit.campaign.test_sweep import _smoke_plan

    plan = _smoke_plan(runs=runs)
    full = run_sweep(plan, tmp_path / "s", jobs=1, progress=False)
    manifest = tmp_path / "s" / "manifest.jsonl"
    header, *records = [json.loads(line) for line in manifest.read_text().splitlines()]
    return plan, full, manifest, header, records


def _write_lines(path, entries):
    import json

    path.write_text("".join(json.dumps(e, sort_keys=True) + "\n" for e in entries))


def test_failed_tasks_run_again_on_resume_and_diverged_ones_do_not(tmp_path):
    import pandas as pd

    from liaison_cli.campaign.sweep.manifest import read_manifest
    from liaison_cli.campaign.sweep.run import run_sweep

    plan, full, manifest, header, records = _written_sweep(tmp_path)
    assert header["format"] == 2 and len(records) == 4
    failed = {**records[0], "status": "error", "reason": "RuntimeError: injected", "rows": []}
    diverged = {**records[1], "status": "diverged", "reason": "position error beyond 1 m"}
    _write_lines(manifest, [header, failed, diverged, *records[2:]])
    again = run_sweep(plan, tmp_path / "s", jobs=1, progress=False)
    assert (again.computed, again.reused) == (1, 3)  # the error only; a diverged run is a result
    _, latest, _ = read_manifest(manifest)
    assert latest[failed["task"]]["status"] == "ok" and latest[diverged["task"]]["status"] == "diverged"
    assert len(manifest.read_text().splitlines()) == 1 + 4 + 1  # the retry appended; the error line kept
    retried = again.runs_table.query(f"point == {failed['point']} and run == {failed['run']}")
    pd.testing.assert_frame_equal(retried, full.runs_table.loc[retried.index])  # the same result as first time
    assert set(again.runs_table.query(f"point == {diverged['point']} and run == {diverged['run']}").status) == \
        {"diverged"}


def test_a_format_1_manifest_is_resumed_in_place(tmp_path):
    import json

    import pandas as pd

    from liaison_cli.campaign.sweep.run import run_sweep

    plan, full, manifest, header, records = _written_sweep(tmp_path)
    _write_lines(manifest, [{**header, "format": 1}, *records[:3]])
    again = run_sweep(plan, tmp_path / "s", jobs=1, progress=False)
    assert (again.computed, again.reused) == (1, 3)
    lines = manifest.read_text().splitlines()
    assert json.loads(lines[0]) == {**header, "format": 1} and len(lines) == 1 + 4  # header kept, one appended
    pd.testing.assert_frame_equal(again.runs_table, full.runs_table)


def test_a_newer_manifest_format_is_one_line_exit_2_and_left_untouched(tmp_path):
    from tests.conftest import SCENARIOS, assert_one_line_error, run_cli_in_process

    out = tmp_path / "s"
    out.mkdir()
    (out / ".liaison-result").write_text("written by liaison\n")
    manifest = out / "manifest.jsonl"
    _write_lines(manifest, [{"kind": "header", "format": 3, "sweep": "t", "points": []}])
    before = manifest.read_bytes() + b'{"task": "torn'  # a torn last line too: not cut away either
    manifest.write_bytes(before)
    proc = run_cli_in_process("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100", "--runs", "1", "--quiet", "--output", out)
    assert_one_line_error(proc, manifest, ["manifest format 3 is newer", "up to 2", "--overwrite"])
    assert manifest.read_bytes() == before


def test_a_symlink_loop_as_the_sweep_folder_is_one_line_exit_4(tmp_path):
    from tests.conftest import SCENARIOS, assert_one_line_error, run_cli_in_process

    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    proc = run_cli_in_process("sweep", SCENARIOS / "smoke.yaml", "--sigma", "100", "--runs", "1", "--output", tmp_path / "a")
    assert_one_line_error(proc, tmp_path / "a", ["Too many levels of symbolic links"], code=4)
