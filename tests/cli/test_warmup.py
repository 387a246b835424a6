"""`liaison warm-up`: its --list names every combination the shipped scenarios and templates need, and it
refuses a bad option in one line. The warm-up itself compiles for minutes on a cold cache: only the slow
test runs it (and then checks that no shipped scenario or template compiles anything more)."""

import os
import subprocess
import sys

import pytest

from tests.conftest import REPO, SCENARIOS, run_cli_in_process, stderr_lines


def _scenarios_and_templates() -> dict:
    """{label as --list prints it: scenario}, read here from the files and templates themselves."""
    from liaison_cli.scenario.loading import load_scenario, read_yaml_value, validate_scenario
    from liaison_cli.scenario.templates import TEMPLATES, template_text

    out = {}
    for path in sorted(SCENARIOS.rglob("*.yaml")):
        if "links" not in path.relative_to(SCENARIOS).parts:  # link files are not scenarios
            out[path.relative_to(SCENARIOS).as_posix()] = load_scenario(path)[0]
    for kind in TEMPLATES:
        out[f"template {kind}"] = validate_scenario(read_yaml_value(template_text(kind)), kind)
    return out


def _needs(scenario) -> tuple:
    """What a scenario's compiled code depends on, as --list spells it: the estimator (and an initial batch
    before an EKF) and the dynamics. The kernels read the model and the observable kinds at run time, so the
    observables are not part of it; --list names the union of its scenarios' observables after them."""
    start = " + initial batch" if scenario.filter.initial_batch_hours is not None else ""
    return f"{scenario.estimator}{start} · {scenario.dynamics}"


def _observables(scenarios) -> str:
    from liaison_cli.measurements.registry import OBSERVABLES

    used = {name for scenario in scenarios for link in scenario.links for name in link.observables}
    return ", ".join(name for name in OBSERVABLES if name in used)


def _listed(stdout: str) -> dict:
    """{combination: [labels]} from --list (continuation lines are indented)."""
    entries, current = {}, None
    for line in stdout.splitlines()[1:]:
        if not line.startswith(" "):
            current, _, line = line.partition(": ")
            entries[current] = []
        entries[current] += [item.strip() for item in line.split(",") if item.strip()]
    return entries


def test_list_names_every_combination_the_shipped_scenarios_and_templates_need():
    proc = run_cli_in_process("warm-up", "--list")
    assert proc.returncode == 0, proc.stderr
    listed = _listed(proc.stdout)
    sources = _scenarios_and_templates()
    groups: dict = {}
    for label, scenario in sources.items():
        groups.setdefault(_needs(scenario), {})[label] = scenario
    expected = {f"{key} · {_observables(members.values())}": set(members) for key, members in groups.items()}
    commands = {name: labels for name, labels in listed.items() if name.startswith("liaison ")}
    runs = {name: set(labels) for name, labels in listed.items() if name not in commands}
    assert runs == expected
    assert sum(len(labels) for labels in runs.values()) == len(sources)  # each named once
    assert proc.stdout.startswith(f"{len(expected)} combinations")
    # The commands whose kernels no run reaches, each on one EKF scenario of the CRTBP.
    assert set(commands) == {"liaison errors", "liaison observability"}
    for labels in commands.values():
        assert len(labels) == 1 and labels[0] in expected["ekf · crtbp · " + _observables(
            groups["ekf · crtbp"].values())]
    assert "template tdoa-pair" in sources and "004/eml2_halo.yaml" in sources and "smoke.yaml" in sources


@pytest.mark.parametrize("value", ["0", "-1", "x", "1.5", ""])
def test_bad_jobs_is_one_line_and_exit_2(value):
    proc = run_cli_in_process("warm-up", "--jobs", value)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr, proc.stderr
    lines = stderr_lines(proc.stderr)
    assert len(lines) == 1 and lines[0].startswith(f"error: --jobs {value!r}:"), proc.stderr
    assert "allowed: a whole number of processes, 1 or more" in lines[0]
    assert proc.stdout == ""  # refused before planning or compiling anything


@pytest.mark.slow
def test_after_warm_up_no_shipped_scenario_or_template_compiles(tmp_path):
    """Warm-up into an empty cache, then every source at its smallest in a new process: numba compiles
    nothing more; and each command warm-up covers (`liaison errors`, `liaison observability`) on its
    representative. About 2-3 min on 2 cores (the warm-up), plus the 004 scenarios' orbit corrections."""
    from liaison_cli.campaign.engine.warmup import COMMANDS

    env = {**os.environ, "LIAISON_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("NUMBA_CACHE_DIR", None)
    warm = subprocess.run([sys.executable, "-m", "liaison_cli", "warm-up", "--jobs", "2"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=1800)
    assert warm.returncode == 0, warm.stderr
    assert "warm-up: compiled" in warm.stdout and "compiled twice" not in warm.stdout, warm.stdout
    # Each scenario and template as a run (the combination's other fields, command "run"), then each command once
    # on its representative; "|" between fields (a template's label has a space in it).
    check = ("from liaison_cli.campaign.engine.warmup import Specialisation, plan, warm_up_one\n"
             "for spec in plan():\n"
             "    fields = [getattr(spec, f) for f in ('estimator', 'dynamics', 'observables', 'initial_batch')]\n"
             "    for source in (spec.sources if spec.command == 'run' else spec.sources[:1]):\n"
             "        one = warm_up_one(Specialisation(*fields, (source,), spec.command))\n"
             "        print(spec.command, source.label, len(one.compiled), one.error or 'ok',"
             " sorted(set(one.compiled)), sep='|')\n")
    proc = subprocess.run([sys.executable, "-c", check], cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=1800)
    assert proc.returncode == 0, proc.stderr
    rows = [line.split("|") for line in proc.stdout.splitlines()]
    assert sorted(label for command, label, *_ in rows if command == "run") == sorted(_scenarios_and_templates())
    assert sorted(command for command, *_ in rows if command != "run") == sorted(COMMANDS)
    assert all(compiled == "0" and status == "ok" for _, _, compiled, status, _ in rows), proc.stdout
