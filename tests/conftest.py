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
