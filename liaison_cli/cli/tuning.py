"""`liaison tune`: each scenario's consistency at its shipped process noise, and the SNC a stated rule chooses."""

import sys
from pathlib import Path

import typer

from liaison_cli.cli.common import (BackendOption, JobsOption, QuietOption, SchedulerOption, SchedulerTimeoutOption,
                                    check_file_output, check_runs, echo_json, fan_out, file_starts_with, json_option,
                                    user_errors)
from liaison_cli.cli.root import app
from liaison_cli.cli.studies import _load_study
from liaison_cli.errors import LiaisonError


@app.command("tune")
@user_errors
def tune(
    scenarios: list[Path] = typer.Argument(..., metavar="SCENARIO...", help="scenario YAML files (labelled by "
                                           "file stem)"),
    ladder: str = typer.Option(None, "--ladder", help="process-noise rungs in m/s^2, a comma list "
                               "[default: 1, 2 and 5 per decade from 1e-10 to 1e-5, run a decade at a time]"),
    runs: int = typer.Option(100, "--runs", min=1, help="Monte Carlo runs per rung (100: a share's 95 % "
                              "interval of about +-1.5-4 points; 20: +-3-9)"),
    jobs: JobsOption = 2,
    backend: BackendOption = "joblib",
    scheduler: SchedulerOption = None,
    scheduler_timeout: SchedulerTimeoutOption = 20.0,
    work: Path = typer.Option(Path("results/tune"), "--work", help="folder of the rungs' sweeps (resumed, reused)"),
    table: Path = typer.Option(Path("results/tune/consistency.md"), "--table",
                               help="the Markdown table to write; the Parquet goes beside it (.parquet); an earlier "
                                    "tune table there is replaced, any other file only with --overwrite"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace existing files given by --table"),
    quiet: QuietOption = False,
    as_json: bool = json_option(),
):
    """Consistency of each scenario's shipped process noise, and the SNC a stated rule chooses on a ladder.

    Example: liaison tune scenarios/smoke.yaml --ladder 1e-9,1e-8,1e-7 --runs 100 --table consistency.md"""
    from liaison_cli.campaign.studies.output import StudyOutput, write_files
    from liaison_cli.campaign.studies.tuning import TuningCase, parse_ladder, provenance, rule_text, tune as run_tuning
    from liaison_cli.report.tuning import format_ladder, format_table, paper_tuned_notes

    check_runs(runs)
    where = fan_out(backend, scheduler, scheduler_timeout)
    rungs = parse_ladder(ladder)
    from liaison_cli.campaign.sweep.grid import check_grid_size  # the sweeps' caps: bounded work before any run

    check_grid_size([("ladder", list(rungs))], len(scenarios), runs)
    if table.suffix != ".md" or table.is_dir():
        raise LiaisonError(f"--table {table}: allowed: a Markdown file path ending in .md (the Parquet goes beside it)")
    check_file_output(table, overwrite, "--table", "a tune table", _tune_markdown)
    check_file_output(table.with_suffix(".parquet"), overwrite, "beside --table", "a tune table", _tune_parquet)
    loaded = _load_study(scenarios)
    cases = [TuningCase(name, scenario, text, str(path)) for path, (name, scenario, text) in zip(scenarios, loaded)]
    frame = run_tuning(cases, rungs, runs, work, jobs, progress=not quiet and sys.stderr.isatty(),
                       on_case=None if quiet else lambda label: typer.echo(f"tune: {label}", err=True), where=where)
    if not as_json:
        typer.echo(format_ladder(frame))
    settle = sorted({(case.scenario.settle_days(), case.label) for case in cases})
    other = [f"{label} {days:g} d" for days, label in settle if days != 1.0]
    settle_note = "filter.settle_days; 1 d" + (f" except {', '.join(other)}" if other else "")
    command = " ".join(["liaison tune", *map(str, scenarios), f"--runs {runs}"]
                       + ([f"--ladder {ladder}"] if ladder else []) + [f"--table {table}"])
    markdown = format_table(frame, rule_text(rungs, runs), command, settle_note, paper_tuned_notes())
    write_files(table.parent, StudyOutput({table.stem: frame}, provenance(cases, rungs, runs, command),
                                          {table.name: markdown}))
    if as_json:
        from liaison_cli.report.json_summary import tune_document

        echo_json(tune_document(frame, rule_text(rungs, runs), table))
        return
    typer.echo(f"wrote {table} and {table.with_suffix('.parquet')}")


_WRITTEN_BY = "Written by `liaison tune "  # the Markdown table's third line (report.tuning.format_table)


def _tune_markdown(path: Path) -> bool:
    """An earlier tune table: its opening says `liaison tune` wrote it."""
    return file_starts_with(path, (_WRITTEN_BY,))


def _tune_parquet(path: Path) -> bool:
    """An earlier tune table's Parquet: liaison's provenance metadata naming the `liaison tune` command."""
    from liaison_cli.storage import read_metadata

    try:
        command = read_metadata(path).get("command")
    except Exception:  # noqa: BLE001 - not readable as a liaison table: not evidence of ours
        return False
    return isinstance(command, str) and command.startswith("liaison tune ")
