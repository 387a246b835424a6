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
