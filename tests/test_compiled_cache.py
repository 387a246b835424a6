"""The compiled-code cache follows the numeric core's source, so no stale machine code can run."""

import os
import subprocess
import sys

import liaison_cli


def test_numba_cache_dir_is_keyed_by_core_source():
    assert os.environ["NUMBA_CACHE_DIR"].endswith(f"numba-{liaison_cli.core_source_hash()}")
    out = subprocess.run(
        [sys.executable, "-c", "import liaison_cli, numba; print(numba.config.CACHE_DIR)"],
        capture_output=True, text=True, check=True,
    )
    assert out.stdout.strip().endswith(liaison_cli.core_source_hash())


def test_hash_covers_callees_of_the_filter_loop(tmp_path, monkeypatch):
    # A change in crtbp.py alone (inlined into the filter loop) must change the key.
    import shutil
    from pathlib import Path

    fake = tmp_path / "liaison_cli"
    shutil.copytree(Path(liaison_cli.__file__).parent, fake, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(liaison_cli, "__file__", str(fake / "__init__.py"))
    before = liaison_cli.core_source_hash()
    (fake / "dynamics" / "crtbp.py").write_text((fake / "dynamics" / "crtbp.py").read_text() + "\n# changed\n")
    assert liaison_cli.core_source_hash() != before


def test_a_cold_cache_is_announced_once_and_a_warm_one_is_silent(tmp_path):
    """The first run on a machine compiles the core (about 15 s) and says so in one line; the next
    run loads the cache and says nothing."""
    from liaison_cli.cli.common import COMPILE_NOTICE
    from tests.conftest import SCENARIOS

    env = {**os.environ, "LIAISON_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("NUMBA_CACHE_DIR", None)
    args = [sys.executable, "-m", "liaison_cli", "run", str(SCENARIOS / "smoke.yaml"), "--runs", "1", "--quiet"]
    cold = subprocess.run([*args, "--output", str(tmp_path / "a")], capture_output=True, text=True, env=env)
    assert cold.returncode == 0, cold.stderr
    assert cold.stderr.count(COMPILE_NOTICE) == 1
    warm = subprocess.run([*args, "--output", str(tmp_path / "b")], capture_output=True, text=True, env=env)
    assert warm.returncode == 0 and warm.stderr == "", warm.stderr
