"""Commands on scenario files themselves: `liaison new` (from a template), `liaison schema`, `liaison validate`,
`liaison scenarios` (what ships, by name); and `liaison version`."""

from pathlib import Path

import typer

from liaison_cli import __version__
from liaison_cli.cli.common import check_file_output, echo_json, file_starts_with, json_option, user_errors
from liaison_cli.cli.root import app
from liaison_cli.errors import LiaisonError


@app.command()
def version():
    """Print the package version.

    Example: liaison version"""
    typer.echo(__version__)


@app.command()
@user_errors
def schema(
    output: Path = typer.Option(None, "--output", help="write it to this file (atomically) instead of printing; "
                                "an earlier schema file there is replaced, any other file only with --overwrite"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing file given by --output"),
):
    """Print the scenario JSON Schema (every key's description, unit and allowed values) for editors.

    Example: liaison schema --output liaison-scenario.schema.json"""
    from liaison_cli.scenario.json_schema import scenario_json_schema_text

    text = scenario_json_schema_text()
    if output is None:
        typer.echo(text, nl=False)
        return
    from liaison_cli.campaign.studies.output import StudyOutput, write_files

    check_file_output(output, overwrite, "--output", "the scenario schema", _schema_file)
    write_files(output.parent, StudyOutput(texts={output.name: text}))
    typer.echo(f"wrote {output}")


def _schema_file(path: Path) -> bool:
    """An earlier `liaison schema --output`: its opening names liaison's schema id."""
    from liaison_cli.scenario.json_schema import SCHEMA_ID

    return file_starts_with(path, (f'"$id": "{SCHEMA_ID}"',))


@app.command()
@user_errors
def validate(
    files: list[Path] = typer.Argument(..., metavar="FILE...", help="scenario or link YAML files"),
    as_json: bool = json_option(),
):
    """Check scenarios (and link files) as `run` (and `budget`) would, without propagating: one line each.

    Example: liaison validate eml2_lunar 004/dro links/turan2022_table2.yaml"""
    from liaison_cli.scenario.loading import check_file

    results = []
    for path in files:
        try:
            check_file(path)
            results.append((path, None))
            if not as_json:
                typer.echo(f"ok: {path}")
        except LiaisonError as exc:  # one line per bad file (on stderr), and on to the next
            results.append((path, str(exc)))
            typer.echo(f"error: {exc}", err=True)
    if as_json:
        from liaison_cli.report.json_summary import validate_document

        echo_json(validate_document(results))
    if any(error is not None for _, error in results):
        raise typer.Exit(2)


@app.command("new")
@user_errors
def new(
    path: Path = typer.Argument(..., metavar="NAME.yaml", help="the scenario file to write (must not exist)"),
    kind: str = typer.Option(..., "--from", metavar="KIND", help="template: crosslink-pair, network, "
                             "nrho-batch, dated-dsn, tdoa-pair or lunar-relay"),
):
    """Write a commented starting scenario from a template; it validates and runs as written.

    Example: liaison new my_pair.yaml --from crosslink-pair && liaison run my_pair.yaml"""
    from liaison_cli.scenario.json_schema import SCHEMA_FILE_NAME
    from liaison_cli.scenario.templates import TEMPLATES, new_scenario

    name = new_scenario(path, kind)
    typer.echo(f"wrote {path} (scenario {name}: {TEMPLATES[kind]}); run it with: liaison run {path}")
    if not (path.parent / SCHEMA_FILE_NAME).exists():
        typer.echo(f"editor help: liaison schema --output {path.parent / SCHEMA_FILE_NAME}")


@app.command("scenarios")
@user_errors
def scenarios(as_json: bool = json_option()):
    """The shipped scenarios and link files, each by the name `liaison run` (or `budget`) takes from any folder,
    with its description; `liaison new --from KIND` writes a template to start your own.

    Example: liaison scenarios; liaison run lunar/elfo_pair --runs 4"""
    from liaison_cli.scenario.shipped import shipped_catalogue
    from liaison_cli.scenario.templates import TEMPLATES

    rows = shipped_catalogue()
    if as_json:
        from liaison_cli.report.json_summary import scenarios_document

        echo_json(scenarios_document(rows, sorted(TEMPLATES)))
        return
    width = max(len(row["name"]) for row in rows)
    for kind in ("scenario", "link file"):
        chosen = [row for row in rows if row["kind"] == kind]
        typer.echo(f"{len(chosen)} shipped {kind}s (liaison {'run' if kind == 'scenario' else 'budget'} NAME):")
        for row in chosen:
            typer.echo(f"  {row['name']:<{width}}  {row['description']}")
    typer.echo(f"templates (liaison new NAME.yaml --from KIND): {', '.join(sorted(TEMPLATES))}")
