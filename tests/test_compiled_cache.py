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
