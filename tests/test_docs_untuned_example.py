"""docs/getting-started.md's untuned formation: its YAML runs as written, with no filter section, and prints the
lines the page shows (numbers aside): the integration step and the process noise the tool chose, and a consistent
verdict for both spacecraft."""

import re

from tests.conftest import REPO, run_cli_in_process

PAGE = REPO / "docs" / "getting-started.md"
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def _shape(lines) -> list[str]:
    return [" ".join(NUMBER.sub("N", line).split()) for line in lines]


def test_the_untuned_formation_runs_and_prints_what_the_page_shows(tmp_path):
    section = PAGE.read_text().split("<!-- untuned-example:", 1)[1]
    scenario = re.search(r"```yaml\n(.*?)```", section, flags=re.S).group(1)
    shown = re.search(r"```text\n(.*?)```", section, flags=re.S).group(1).strip().splitlines()
    assert "filter:" not in scenario  # every default applies
    path = tmp_path / "relay.yaml"
    path.write_text(scenario)
    proc = run_cli_in_process("run", path, "--output", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    printed = proc.stdout.splitlines()[: len(shown)]
    assert _shape(printed) == _shape(shown), proc.stdout
    verdicts = [line.split()[-1] for line in printed if line.startswith(("Gateway ", "Orbiter ")) and "±" in line]
    assert verdicts == ["yes", "yes"]
    assert "20/20 runs ok" in proc.stdout
