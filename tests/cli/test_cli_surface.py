"""What the command line shows and accepts (issue 35): `--help` gives no flag a value (`<bool>` was shown beside
every one); -v works after the command as before it; `schema --output` and `tune --table` replace only their
own earlier files unless --overwrite is given (they overwrote any file)."""

import logging

import pytest
import typer.main
from typer.testing import CliRunner

from liaison_cli.cli import app
from liaison_cli.cli.common import check_file_output
from liaison_cli.errors import OutputExistsError
from tests.conftest import SCENARIOS, assert_one_line_error, run_cli_in_process


def _commands(command, path):
    """(path, command) for `command` and everything below it."""
    yield path, command
    for name, sub in getattr(command, "commands", {}).items():
        yield from _commands(sub, [*path, name])


ALL_COMMANDS = list(_commands(typer.main.get_command(app), []))


@pytest.mark.parametrize("path", [p for p, _ in ALL_COMMANDS], ids=lambda p: " ".join(p) or "liaison")
def test_help_shows_no_value_for_a_flag(path):
    result = CliRunner().invoke(app, [*path, "--help"], terminal_width=100)
    assert result.exit_code == 0, result.output
    assert "<bool>" not in result.output, result.output
    assert "--help" in result.output


def test_every_command_takes_verbose_after_its_name():
    leaves = [(path, command) for path, command in ALL_COMMANDS if not hasattr(command, "commands")]
    assert len(leaves) > 20
    for path, command in leaves:
        assert any({"-v", "--verbose"} <= set(param.opts) for param in command.params), path


def test_verbose_after_the_command_is_verbose_before_it(tmp_path):
    logger = logging.getLogger("liaison")
    after = run_cli_in_process("run", SCENARIOS / "smoke.yaml", "--runs", "1", "--quiet", "--output", tmp_path / "a",
                               "-v")
    assert after.returncode == 0 and "info: read and checked" in after.stderr, after.stderr
    before = run_cli_in_process("-v", "validate", SCENARIOS / "smoke.yaml")
    plain = run_cli_in_process("validate", SCENARIOS / "smoke.yaml")
    assert before.returncode == plain.returncode == 0
    assert logger.level == logging.WARNING  # set again by every command: -v on one does not leak into the next


def test_schema_output_replaces_its_own_file_and_refuses_any_other(tmp_path):
    path = tmp_path / "liaison-scenario.schema.json"
    assert run_cli_in_process("schema", "--output", path).returncode == 0
    written = path.read_text()
    path.write_text(written.replace('"title"', '"title" ', 1))  # an older schema of ours: replaced on a rerun
    assert run_cli_in_process("schema", "--output", path).returncode == 0 and path.read_text() == written
    mine = tmp_path / "notes.json"
    mine.write_text('{"my": "notes"}\n')
    refused = run_cli_in_process("schema", "--output", mine)
    assert_one_line_error(refused, mine, ["liaison did not write", "--overwrite"])
    assert mine.read_text() == '{"my": "notes"}\n'
    assert run_cli_in_process("schema", "--output", mine, "--overwrite").returncode == 0
    assert mine.read_text() == written
    assert_one_line_error(run_cli_in_process("schema", "--output", tmp_path, "--overwrite"), tmp_path,
                          ["a directory"])


@pytest.mark.parametrize("foreign", ["table.md", "table.parquet"])
def test_tune_refuses_a_table_it_did_not_write_before_any_run(tmp_path, foreign):
    (tmp_path / foreign).write_text("my own table\n")
    refused = run_cli_in_process("tune", SCENARIOS / "smoke.yaml", "--runs", "1", "--ladder", "1e-9", "--work",
                                 tmp_path / "work", "--table", tmp_path / "table.md")
    assert_one_line_error(refused, tmp_path / foreign, ["liaison did not write", "--overwrite"])
    assert (tmp_path / foreign).read_text() == "my own table\n" and not (tmp_path / "work").exists()


def test_tune_replaces_its_own_earlier_table(tmp_path):
    """Ownership by content: the Markdown's `Written by `liaison tune` line, the Parquet's provenance command."""
    import pandas as pd

    from liaison_cli.cli.tuning import _WRITTEN_BY, _tune_markdown, _tune_parquet
    from liaison_cli.storage import write_parquet_atomic

    md, parquet = tmp_path / "t.md", tmp_path / "t.parquet"
    md.write_text(f"# Consistency\n\n{_WRITTEN_BY}scenarios/smoke.yaml --runs 20`; do not edit by hand.\n")
    write_parquet_atomic(pd.DataFrame({"x": [1.0]}), parquet, {"command": "liaison tune scenarios/smoke.yaml"})
    check_file_output(md, False, "--table", "a tune table", _tune_markdown)
    check_file_output(parquet, False, "beside --table", "a tune table", _tune_parquet)
    write_parquet_atomic(pd.DataFrame({"x": [1.0]}), parquet, {"command": "liaison sweep"})
    with pytest.raises(OutputExistsError):
        check_file_output(parquet, False, "beside --table", "a tune table", _tune_parquet)


def _leaf_commands():
    """(path, click command) of every leaf command of the CLI."""
    import click
    import typer.main

    from liaison_cli.cli import app

    root = typer.main.get_command(app)
    context = click.Context(root)

    def walk(command, path):
        if hasattr(command, "list_commands"):
            for name in command.list_commands(context):
                yield from walk(command.get_command(context, name), [*path, name])
        else:
            yield path, command

    return list(walk(root, [])), root


SCENARIO_PARAMETERS = ("scenario", "scenarios", "scenario_args", "scenario_opts", "link_file", "files")
RESULT_PARAMETERS = ("result", "sweep_dir", "folder", "result_dir")  # folders an earlier command must have written


def test_every_command_has_an_example_that_parses_and_names_what_ships(tmp_path, monkeypatch):
    """issue 47: 11 commands had no --help example, and the examples used checkout paths. Every leaf command's help
    has an `Example:` line; each command in it (`;`- or `&&`-separated) parses with that command's own options, and
    every scenario or link file it names is a shipped name (scenario.shipped) or a file an earlier command of the
    example writes, so it works from an empty folder (benchmarks/wheel_walk.py runs them all from a wheel)."""
    import re
    import shlex

    from liaison_cli.scenario.shipped import shipped_by_name, shipped_link_by_name

    monkeypatch.chdir(tmp_path)  # an empty folder: names resolve to what ships, not to this checkout's files
    commands, root = _leaf_commands()
    assert len(commands) >= 26
    for path, command in commands:
        text = " ".join((command.help or "").split())
        found = re.search(r"Examples?: (.*)$", text)
        assert found, f"liaison {' '.join(path)}: no Example in its help"
        written = set()
        for line in re.split(r";\s*|\s*&&\s*", found.group(1).rstrip(".")):
            words = shlex.split(re.sub(r"\(.*?\)", "", line))
            assert words[0] == "liaison", line
            target, rest = root, words[1:]
            while hasattr(target, "list_commands"):
                target, rest = target.get_command(None, rest[0]), rest[1:]
            parsed = target.make_context("liaison", list(rest)).params  # unknown options or bad values raise here
            for name in SCENARIO_PARAMETERS:
                values = parsed.get(name) or []
                for value in [values] if not isinstance(values, (list, tuple)) else values:
                    assert str(value) in written or shipped_by_name(value) or shipped_link_by_name(value), (line, value)
            for name in RESULT_PARAMETERS:
                if parsed.get(name) is not None:
                    assert str(parsed[name]) in written, (line, name, "no earlier command of the example writes it")
            written |= {str(v) for v in parsed.values() if isinstance(v, (str, type(tmp_path)))}
            written |= _default_outputs(" ".join(words[1:len(words) - len(rest)]), parsed)


def _default_outputs(name: str, parsed: dict) -> set:
    """The result folder a command (`name`: its words, e.g. "run", "plot run") writes when no --output is given (the
    docs' defaults)."""
    from pathlib import Path

    if parsed.get("output") is not None:
        return set()
    if name == "run":
        return {f"results/{Path(str(parsed['scenario'])).stem}"}
    if name == "sweep" and not (parsed.get("scenario_args") or parsed.get("scenario_opts")):
        return {f"results/sweep-{parsed.get('name') or 'fig15'}"}
    return set()
