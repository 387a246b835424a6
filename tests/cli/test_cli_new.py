"""`liaison new NAME.yaml --from KIND`: every template is written with the schema modeline, passes the
independent JSON Schema check and `validate`, and runs as written; an existing file or an unknown template
is one line, exit 2, and nothing is written."""

import json

import pytest
from typer.testing import CliRunner

from liaison_cli.cli import app
from liaison_cli.scenario.json_schema import MODELINE_PREFIX, scenario_json_schema_text
from liaison_cli.scenario.schema import read_scenario_text
from liaison_cli.scenario.templates import TEMPLATES


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.mark.parametrize("kind", sorted(TEMPLATES))
def test_every_template_validates_and_runs_as_written(tmp_path, kind):
    jsonschema = pytest.importorskip("jsonschema")
    path = tmp_path / "my_study.yaml"
    made = invoke("new", path, "--from", kind)
    assert made.exit_code == 0, made.output
    text = path.read_text()
    assert text.startswith(MODELINE_PREFIX)
    assert "real study" in text  # the comments say what to change
    data = read_scenario_text(path)[0]  # the loader's YAML reading (1.2 floats such as 2.25e9)
    assert data["name"] == "my_study"
    jsonschema.Draft202012Validator(json.loads(scenario_json_schema_text())).validate(data)
    checked = invoke("validate", path)
    assert checked.exit_code == 0 and checked.stdout.strip() == f"ok: {path}"
    ran = invoke("run", path, "--jobs", "1", "--quiet", "--output", tmp_path / "out", "--json")
    assert ran.exit_code == 0, ran.output
    summary = json.loads(ran.stdout)
    assert summary["runs_ok"] == summary["runs"] == data["monte_carlo"]["runs"]
    assert all(figures["rms_position_m"] > 0 for figures in summary["spacecraft"].values())


def test_new_refuses_an_existing_file(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("my own notes\n")
    result = invoke("new", path, "--from", "crosslink-pair")
    assert result.exit_code == 2
    assert result.stderr.strip().count("\n") == 0 and str(path) in result.stderr and "exists" in result.stderr
    assert path.read_text() == "my own notes\n"


def test_new_refuses_an_unknown_template(tmp_path):
    path = tmp_path / "mine.yaml"
    result = invoke("new", path, "--from", "halo-trio")
    assert result.exit_code == 2
    assert result.stderr.strip().count("\n") == 0
    assert "'halo-trio'" in result.stderr and "crosslink-pair" in result.stderr
    assert not path.exists()


def test_the_help_names_every_template():
    """The --from help is written out (importing the templates would load the schema on every Tab press)."""
    import inspect

    from liaison_cli.cli.scenario_files import new

    help_text = inspect.signature(new).parameters["kind"].default.help
    assert all(kind in help_text for kind in TEMPLATES) and help_text.count(",") + 2 == len(TEMPLATES)  # a, b, c, d or e
