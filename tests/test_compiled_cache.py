"""The compiled-code cache follows the numeric core's source, so no stale machine code can run."""

import os
import subprocess
import sys
from pathlib import Path

import liaison_cli


def test_numba_cache_dir_is_keyed_by_core_source():
    assert os.environ["NUMBA_CACHE_DIR"].endswith(f"numba-{liaison_cli.core_source_hash()}")
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}  # as a fresh shell
    for imports in ("import liaison_cli, numba", "import numba, liaison_cli"):  # numba first: it read the variable
        out = subprocess.run([sys.executable, "-c", f"{imports}; print(numba.config.CACHE_DIR)"], env=env,
                             capture_output=True, text=True, check=True)
        assert out.stdout.strip().endswith(liaison_cli.core_source_hash()), imports


def test_numba_imported_first_still_caches_in_the_keyed_folder(tmp_path):
    """A kernel compiled after `import numba` came before liaison lands in the keyed cache, not beside its
    source (where its key would ignore the callees)."""
    script = ("import numba, liaison_cli; from liaison_cli.dynamics.crtbp import jacobi_constant; "
              "import numpy as np; jacobi_constant(np.ones(6), 0.01)")
    env = {**os.environ, "LIAISON_CACHE_DIR": str(tmp_path)}
    env.pop("NUMBA_CACHE_DIR", None)
    subprocess.run([sys.executable, "-c", script], env=env, check=True, capture_output=True)
    assert list(tmp_path.rglob("crtbp.jacobi_constant-*.nbi")), sorted(tmp_path.rglob("*"))


def _core_copy(tmp_path, monkeypatch):
    """A copy of the package that core_source_hash reads instead of the real one."""
    import shutil
    from pathlib import Path

    fake = tmp_path / "liaison_cli"
    shutil.copytree(Path(liaison_cli.__file__).parent, fake, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(liaison_cli, "__file__", str(fake / "__init__.py"))
    return fake


def test_hash_covers_callees_of_the_filter_loop(tmp_path, monkeypatch):
    # A code change in crtbp.py alone (inlined into the filter loop) must change the key.
    crtbp = _core_copy(tmp_path, monkeypatch) / "dynamics" / "crtbp.py"
    before = liaison_cli.core_source_hash()
    crtbp.write_text(crtbp.read_text() + "\nEDITED_CONSTANT = 1.0\n")
    assert liaison_cli.core_source_hash() != before


def test_a_changed_number_in_the_code_changes_the_key(tmp_path, monkeypatch):
    crtbp = _core_copy(tmp_path, monkeypatch) / "dynamics" / "crtbp.py"
    text = crtbp.read_text()
    assert "0.5" in text
    before = liaison_cli.core_source_hash()
    crtbp.write_text(text.replace("0.5", "0.50001", 1))
    assert liaison_cli.core_source_hash() != before


def test_comments_and_docstrings_do_not_change_the_key(tmp_path, monkeypatch):
    """Edited prose (a module, function or class docstring, a comment, blank lines that shift every line
    number) keeps the compiled cache: only code is hashed."""
    crtbp = _core_copy(tmp_path, monkeypatch) / "dynamics" / "crtbp.py"
    text = crtbp.read_text()
    before = liaison_cli.core_source_hash()
    assert text.startswith('"""') and '    """' in text
    edited = ('"""An edited module docstring."""\n\n# a new comment\n\n' + text.split('"""', 2)[2]).replace(
        '    """', '    """Reworded. ', 1)
    crtbp.write_text(edited + "\n# a comment at the end\n")
    assert liaison_cli.core_source_hash() == before


def test_code_digest_strips_prose_only():
    from liaison_cli import code_digest

    plain = b"def f(x):\n    return 2 * x\n"
    documented = b'"""Module."""\n# note\n\ndef f(x):\n    """Twice x."""\n    return 2 * x  # why\n'
    assert code_digest(documented) == code_digest(plain)
    assert code_digest(b"def f(x):\n    return 3 * x\n") != code_digest(plain)
    assert code_digest(b"def f(x):\n    return '2' * x\n") != code_digest(plain)  # a string in code counts


def test_a_cold_cache_is_announced_once_and_a_warm_one_is_silent(tmp_path):
    """A run that has to compile says so in one line; the next run loads the cache and says nothing.

    The "cold" cache is this session's compiled cache with one kernel taken out (the truth's RK4, which the
    run calls from Python), so the run compiles just that one (a few seconds) instead of the whole core (about
    15 s): the notice fires on the first compilation of any liaison code, whichever it is."""
    import shutil

    from liaison_cli.cli.common import COMPILE_NOTICE
    from tests.conftest import SCENARIOS, run_cli_in_process

    warmed = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--quiet", "--output", tmp_path / "w")
    assert warmed.returncode == 0, warmed.stderr  # this session's cache now holds what the run needs
    session_cache = Path(liaison_cli._numba_cache_dir())
    cache = tmp_path / "cache"
    try:  # other workers may be writing into the session's cache (numba: a temporary file, then a rename)
        shutil.copytree(session_cache, cache / session_cache.name, ignore=shutil.ignore_patterns("*.tmp*"))
    except shutil.Error:
        pass  # a file that vanished mid-copy is only one more kernel to compile: the notice still comes once
    taken_out = list((cache / session_cache.name).rglob("rk4.rk4_states_forced-*"))
    assert taken_out, "the truth's RK4 is in the cache"
    for path in taken_out:
        path.unlink()
    env = {**os.environ, "LIAISON_CACHE_DIR": str(cache)}
    env.pop("NUMBA_CACHE_DIR", None)
    args = [sys.executable, "-m", "liaison_cli", "run", str(SCENARIOS / "smoke.yaml"), "--runs", "1", "--quiet"]
    cold = subprocess.run([*args, "--output", str(tmp_path / "a")], capture_output=True, text=True, env=env)
    assert cold.returncode == 0, cold.stderr
    assert cold.stderr.count(COMPILE_NOTICE) == 1
    assert list((cache / session_cache.name).rglob("rk4.rk4_states_forced-*.nbc")), "the cold run cached it again"
    warm = subprocess.run([*args, "--output", str(tmp_path / "b")], capture_output=True, text=True, env=env)
    assert warm.returncode == 0 and warm.stderr == "", warm.stderr


# A small kernel and how to tell whether numba compiled it or loaded it: the compile events of liaison code.
_JACOBI = """
import sys
import liaison_cli  # first, as the CLI does: its compile target (generic) is set before numba is imported
from numba.core import event
compiled = []
class Recorder(event.Listener):
    def on_start(self, ev):
        compiled.append(ev.data["dispatcher"].py_func.__qualname__)
    def on_end(self, ev):
        pass
event.register("numba:compile", Recorder())
import numpy as np
from liaison_cli.dynamics.crtbp import jacobi_constant
print(repr(float(jacobi_constant(np.array([0.8, 0.1, 0.05, 0.01, 0.2, 0.0]), 0.0121505856))))
print("compiled" if compiled else "loaded")
"""


def _jacobi_in(package_parent: Path, cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(package_parent), "LIAISON_CACHE_DIR": str(cache)}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("NUMBA_CPU_NAME", None)  # liaison's own default (the generic target), as on a user's machine
    return subprocess.run([sys.executable, "-c", _JACOBI], env=env, capture_output=True, text=True, cwd=package_parent)


def _package_at(folder: Path) -> Path:
    import shutil

    shutil.copytree(Path(liaison_cli.__file__).parent, folder / "liaison_cli",
                    ignore=shutil.ignore_patterns("__pycache__", "shipped_scenarios"))
    return folder


def test_a_cache_built_elsewhere_serves_another_checkout_and_user(tmp_path):
    """A cache filled by one copy of the package (one path, one user's cache folder) and copied into another
    user's cache folder serves a second copy at another path, with other file times: nothing is compiled. numba
    alone keyed its folders on the source's absolute path (and the host CPU), so no such cache could serve."""
    import shutil

    first, second = _package_at(tmp_path / "checkout-a"), _package_at(tmp_path / "elsewhere" / "checkout-b")
    built = _jacobi_in(first, tmp_path / "cache-a")
    assert built.returncode == 0 and built.stdout.split()[-1] == "compiled", built.stderr
    shutil.copytree(tmp_path / "cache-a", tmp_path / "cache-b")
    used = _jacobi_in(second, tmp_path / "cache-b")
    assert used.returncode == 0 and used.stderr == "", used.stderr
    assert used.stdout.split() == [built.stdout.split()[0], "loaded"]


def test_a_damaged_cache_entry_is_one_line_then_compiled_again(tmp_path):
    """A truncated data file or index (an interrupted copy) is removed with one line naming it, compiled again
    with the same number, and the next process loads the sound entry silently; never numba's traceback."""
    from liaison_cli.compiled_cache import DAMAGED_NOTICE

    checkout, cache = _package_at(tmp_path / "checkout"), tmp_path / "cache"
    sound = _jacobi_in(checkout, cache)
    assert sound.returncode == 0, sound.stderr
    for pattern in ("crtbp.jacobi_constant-*.nbc", "crtbp.jacobi_constant-*.nbi"):
        (damaged,) = cache.rglob(pattern)
        damaged.write_bytes(damaged.read_bytes()[: damaged.stat().st_size // 2])
        healed = _jacobi_in(checkout, cache)
        assert healed.returncode == 0 and "Traceback" not in healed.stderr, healed.stderr
        lines = healed.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(DAMAGED_NOTICE) and "jacobi_constant" in lines[0], lines
        assert healed.stdout.split() == [sound.stdout.split()[0], "compiled"]
        again = _jacobi_in(checkout, cache)
        assert again.stderr == "" and again.stdout.split() == [sound.stdout.split()[0], "loaded"], again.stderr


def test_warm_up_into_a_folder_it_cannot_write_is_one_line_before_compiling(tmp_path):
    from tests.conftest import run_cli_in_process, stderr_lines

    blocker = tmp_path / "a-file"
    blocker.write_text("")
    proc = run_cli_in_process("warm-up", "--cache-dir", blocker / "cache")
    assert proc.returncode == 4 and "Traceback" not in proc.stderr, proc.stderr
    (line,) = stderr_lines(proc.stderr)
    assert str(blocker) in line and "Not a directory" in line
    assert proc.stdout == ""


# Holds jacobi_constant's compile lock as a process that has missed it and is compiling it would, until told
# on stdin to compile it (and save it) or until it is killed.
_HOLDER = """
import sys
import liaison_cli
import numpy as np
from liaison_cli import compiled_cache
from liaison_cli.dynamics.crtbp import jacobi_constant
assert compiled_cache._acquire_compile_lock(jacobi_constant._cache)
print("held", flush=True)
sys.stdin.readline()
print(repr(float(jacobi_constant(np.array([0.8, 0.1, 0.05, 0.01, 0.2, 0.0]), 0.0121505856))), flush=True)
print(sum(depth for _, depth in compiled_cache._compiling.values()), flush=True)  # its own hold only: 1
"""
# _JACOBI, then how many compile locks the process still holds once its call returned (a load after waiting
# releases the lock it took).
_WAITER = _JACOBI + "from liaison_cli import compiled_cache\nprint(len(compiled_cache._compiling))\n"


def _holding(checkout: Path, cache: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(checkout), "LIAISON_CACHE_DIR": str(cache)}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("NUMBA_CPU_NAME", None)
    holder = subprocess.Popen([sys.executable, "-c", _HOLDER], env=env, cwd=checkout, stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert holder.stdout.readline().strip() == "held", holder.stderr.read()
    return holder


def _waiting(checkout: Path, cache: Path) -> subprocess.Popen:
    """The _JACOBI process, started while the holder compiles; it is still waiting 4 s later (unheld, it would
    have compiled the kernel and left in about a second)."""
    env = {**os.environ, "PYTHONPATH": str(checkout), "LIAISON_CACHE_DIR": str(cache)}
    env.pop("NUMBA_CACHE_DIR", None)
    env.pop("NUMBA_CPU_NAME", None)
    waiter = subprocess.Popen([sys.executable, "-c", _WAITER], env=env, cwd=checkout, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
    try:
        waiter.wait(timeout=4)
    except subprocess.TimeoutExpired:
        return waiter
    raise AssertionError(f"it did not wait for the compiling process: {waiter.communicate()}")


def test_a_function_another_process_is_compiling_is_waited_for_and_loaded(tmp_path):
    """Two processes that miss one function at once compile it once: the second waits for the first's save and
    loads it (warm-up's processes and test workers compiled the same kernels side by side)."""
    checkout, cache = _package_at(tmp_path / "checkout"), tmp_path / "cache"
    holder = _holding(checkout, cache)
    waiter = _waiting(checkout, cache)
    held, _ = holder.communicate("go\n", timeout=120)
    value, holder_locks = held.split()
    out, err = waiter.communicate(timeout=120)
    assert holder.returncode == 0 and waiter.returncode == 0 and err == "", err
    assert out.split() == [value, "loaded", "0"] and holder_locks == "1"  # the save released the compile's


def test_a_compiling_process_that_dies_releases_the_function(tmp_path):
    """A process killed while it compiles (its lock goes with it) leaves the waiting one to compile the
    function itself, with the same number as an undisturbed compile."""
    checkout, cache = _package_at(tmp_path / "checkout"), tmp_path / "cache"
    reference = _jacobi_in(checkout, tmp_path / "another-cache")
    holder = _holding(checkout, cache)
    waiter = _waiting(checkout, cache)
    holder.kill()
    holder.communicate()
    out, err = waiter.communicate(timeout=120)
    assert waiter.returncode == 0 and err == "", err
    assert out.split() == [reference.stdout.split()[0], "compiled", "0"]


def test_a_compile_that_fails_releases_its_lock_at_once(monkeypatch):
    """A compile that raises (a typing error here) never saves; its lock is released when the compile ends,
    not held until the process leaves (a later process would wait COMPILE_WAIT_S for nothing)."""
    import numpy as np
    import pytest
    from numba import njit

    from liaison_cli import compiled_cache
    from liaison_cli.dynamics import crtbp

    taken = []
    acquire = compiled_cache._acquire_compile_lock

    def recorded(cache):
        taken.append(acquire(cache))
        return taken[-1]

    monkeypatch.setattr(compiled_cache, "_acquire_compile_lock", recorded)
    held_before = dict(compiled_cache._compiling)
    kernel = njit(cache=True)(crtbp.jacobi_constant.py_func)  # the same module's cache, a fresh dispatcher
    with pytest.raises(Exception):
        kernel("not a state", np.float64(0.1))  # typing fails: strings have no arithmetic here
    assert True in taken, "the compile took no lock: nothing was tested"
    assert compiled_cache._compiling == held_before


def test_reading_an_entry_back_takes_no_lock():
    """warm-up's read-back (unloadable) probes the cache; a miss there is no compile, so it must hold nothing
    after it (nothing would release it)."""
    from liaison_cli import compiled_cache
    from liaison_cli.campaign.engine.warmup import unloadable

    from numba import types

    held_before = dict(compiled_cache._compiling)
    never_compiled = (types.float64, types.float64)  # jacobi_constant takes a state array
    missing = unloadable([("liaison_cli.dynamics.crtbp", "jacobi_constant", never_compiled)])
    assert len(missing) == 1 and compiled_cache._compiling == held_before
