import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCENARIOS = REPO / "scenarios"


@pytest.fixture
def scenarios_dir():
    return SCENARIOS


def run_cli(*args, cwd=None):
    """Run the installed CLI in a subprocess (real exit code, real stderr)."""
    import subprocess

    return subprocess.run(
        [sys.executable, "-m", "liaison_cli", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd or REPO,
        timeout=600,
    )


def edited_scenario(tmp_path, source_name: str, old: str, new: str) -> Path:
    """A copy of scenarios/<source_name> with one text edit (the edit must apply)."""
    text = (SCENARIOS / source_name).read_text()
    assert old in text, old
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(old, new))
    return path


def assert_one_line_error(proc, path, fragments, code: int = 2) -> None:
    """Exit code, no traceback, one line naming the file and containing every fragment."""
    assert proc.returncode == code and "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0], proc.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
