"""The root command: shell completion (`--install-completion` / `--show-completion`) and what it relies on.

Completion works by running `liaison` on every Tab press with `_LIAISON_COMPLETE` set: the answer must come
quickly, so the command modules import pandas, numba, matplotlib and the campaign code inside the commands,
not at the top (the reason cli/run.py and the others keep their imports lazy; the first CLI kept completion
off). These tests hold both: the completion answers, and answering loads none of the heavy libraries."""

import contextlib
import os
import subprocess
import sys

from typer.testing import CliRunner

from liaison_cli.cli import app

from tests.conftest import REPO, SCENARIOS
HEAVY = ["pandas", "numba", "matplotlib", "pyarrow", "scipy", "liaison_cli.campaign", "liaison_cli.scenario.loading",
         "liaison_cli.scenario.scenario_model"]


# Typer names the shell from the process tree (shellingham) unless told not to: a suite started detached (a CI
# runner, `nohup`, a background job) has no shell above it, so these tests name bash themselves.
NAMED_SHELL = {"_TYPER_COMPLETE_TEST_DISABLE_SHELL_DETECTION": "1"}


def test_show_completion_prints_the_bash_script(monkeypatch):
    monkeypatch.setenv(*next(iter(NAMED_SHELL.items())))
    result = CliRunner().invoke(app, ["--show-completion", "bash"], prog_name="liaison")
    assert result.exit_code == 0, result.output
    assert "_LIAISON_COMPLETE=complete_bash" in result.stdout and "complete " in result.stdout


def test_install_completion_writes_into_the_users_shell_setup_only(tmp_path):
    env = {**os.environ, "HOME": str(tmp_path), "SHELL": "/bin/bash", **NAMED_SHELL}
    proc = subprocess.run([sys.executable, "-m", "liaison_cli", "--install-completion", "bash"], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    script = tmp_path / ".bash_completions" / "liaison.sh"
    assert "_LIAISON_COMPLETE=complete_bash" in script.read_text()
    assert str(script) in (tmp_path / ".bashrc").read_text()


def test_a_tab_press_is_answered_without_loading_the_heavy_libraries():
    code = ("import atexit, sys\n"
            f"atexit.register(lambda: print('loaded:' + ','.join(m for m in {HEAVY!r} if m in sys.modules)))\n"
            "from liaison_cli.cli import app\napp(prog_name='liaison')\n")
    env = {**os.environ, "_LIAISON_COMPLETE": "complete_bash", "COMP_WORDS": "liaison plot r", "COMP_CWORD": "2"}
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=120)
    lines = proc.stdout.split()
    assert "run" in lines and "fig15" not in lines, proc.stdout
    assert lines[-1] == "loaded:", proc.stdout


def test_version_option_and_command_agree():
    from liaison_cli import __version__

    for args in (["--version"], ["version"]):
        result = CliRunner().invoke(app, args)
        assert result.exit_code == 0 and result.stdout == f"{__version__}\n", result.stderr


def test_version_with_verbose_prints_the_arithmetic_in_either_order():
    """`--version -v` and `-v --version` (and --verbose) print the version, then one `key: value` line per key of
    the record result metadata carries (liaison_cli.provenance); plain --version stays one line."""
    import numpy as np

    from liaison_cli import __version__
    from liaison_cli.provenance import arithmetic_provenance

    expected = [__version__] + [f"{key}: {value}" for key, value in arithmetic_provenance().items()]
    for args in (["--version", "--verbose"], ["--version", "-v"], ["-v", "--version"], ["--verbose", "--version"]):
        result = CliRunner().invoke(app, args)
        assert result.exit_code == 0, result.stderr
        assert result.stdout.splitlines() == expected, args
    assert f"numpy: {np.__version__}" in expected and any(line.startswith("numpy_blas_core: ") for line in expected)


def test_version_with_verbose_runs_no_command():
    from liaison_cli import __version__

    result = CliRunner().invoke(app, ["-v", "--version", "run", "no-such-file.yaml"])
    assert result.exit_code == 0 and result.stdout.splitlines()[0] == __version__, result.output
    assert "no-such-file" not in result.output


def test_shipped_scenarios_run_by_name_from_any_folder(tmp_path):
    """Issue 47: after `pip install`, `liaison run eml2_lunar` in an empty folder was 'no such scenario file'.
    A name that is no file there is the shipped scenario it names (with or without .yaml or scenarios/), with
    one note; a file there wins; another name is still refused in one line."""
    from tests.conftest import run_cli

    names = ("smoke", "smoke.yaml", "scenarios/smoke.yaml", "004/dro")
    proc = run_cli("validate", *names, cwd=tmp_path)  # one process for the four: each says which file it took
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("the shipped scenario") == 4
    assert proc.stdout.strip().splitlines() == [f"ok: {name}" for name in names]
    for command in (["run", "smoke", "--runs", "1", "--jobs", "1", "--quiet"], ["errors", "smoke", "--quiet"]):
        ran = _in_process_here(tmp_path, *command)  # the same parsing and files, without a new interpreter
        assert ran.exit_code == 0, ran.output
    assert (tmp_path / "results" / "smoke" / "summary.parquet").is_file()
    assert (tmp_path / "results" / "smoke-errors").is_dir()
    own = tmp_path / "smoke.yaml"  # a file of the user's wins, and no note is said
    own.write_text((SCENARIOS / "smoke.yaml").read_text().replace("name: smoke", "name: mine"))
    proc = run_cli("validate", "smoke.yaml", cwd=tmp_path)
    assert proc.returncode == 0 and "shipped" not in proc.stderr, proc.stderr
    missing = run_cli("validate", "no_such_scenario", cwd=tmp_path)
    assert missing.returncode == 2 and "no such scenario file" in missing.stderr


def _in_process_here(folder, *args):
    """The CLI in this process with `folder` as the working folder (CliRunner; conftest's run_cli_in_process
    works from the repository)."""
    import contextlib

    from typer.testing import CliRunner

    from liaison_cli.cli import app

    with contextlib.chdir(folder):
        return CliRunner().invoke(app, [str(a) for a in args])


def test_liaison_scenarios_lists_every_shipped_name_and_each_resolves(tmp_path):
    """issue 47: `liaison scenarios` lists what ships, by the names `run` and `budget` take from any folder; every
    listed name resolves from an empty folder, every shipped YAML is listed, and --json gives the same rows."""
    import json

    from liaison_cli.scenario.shipped import shipped_by_name, shipped_dir, shipped_link_by_name

    text = _in_process_here(tmp_path, "scenarios")
    assert text.exit_code == 0, text.output
    listed = _in_process_here(tmp_path, "scenarios", "--json")
    document = json.loads(listed.stdout)
    names = [row["name"] for row in document["shipped"]]
    assert len(names) == len(list(shipped_dir().rglob("*.yaml"))) and "lunar/elfo_pair" in names
    with contextlib.chdir(tmp_path):
        for row in document["shipped"]:
            resolve = shipped_by_name if row["kind"] == "scenario" else shipped_link_by_name
            assert resolve(row["name"]) is not None, row
            assert f"  {row['name']}" in text.stdout
    assert "crosslink-pair" in document["templates"] and set(document) == {"command", "liaison_version", "shipped",
                                                                            "templates"}
