"""`liaison run`, `liaison compare` and `liaison table3`: run scenarios' Monte Carlo campaigns and print their
summaries (as text, or with --json as JSON)."""

import logging
import sys
import time
from pathlib import Path

import typer

from liaison_cli.cli.common import (
    EXIT_ALL_DIVERGED,
    BackendOption,
    JobsOption,
    QuietOption,
    SchedulerOption,
    SchedulerTimeoutOption,
    check_runs,
    echo_json,
    fail,
    fan_out,
    json_option,
    refuse_repeated_labels,
    user_errors,
)
from liaison_cli.cli.root import app
from liaison_cli.report.run_text import (
    CONSISTENCY_COLUMNS,
    format_advice as _format_advice,
    format_consistency as _format_consistency,
    format_prediction as _format_prediction,
    format_ric as _format_ric,
    format_smoothed as _format_smoothed,
    format_summary as _format_summary,
    rejection_line as _rejection_line,
    status_line as _status_line,
)
from liaison_cli.scenario.shipped import scenario_folder

log = logging.getLogger("liaison")


@app.command()
@user_errors
def run(
    scenario: Path = typer.Argument(..., help="scenario YAML file"),
    runs: int = typer.Option(None, "--runs", min=1, help="Monte Carlo runs (default: the scenario's)"),
    jobs: JobsOption = 2,
    backend: BackendOption = "joblib",
    scheduler: SchedulerOption = None,
    scheduler_timeout: SchedulerTimeoutOption = 20.0,
    output: Path = typer.Option(None, "--output", help="result folder (default: results/<scenario name>, "
                                "replaced by the next run of the same command; what other commands wrote into it is kept)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder given by --output"),
    float64: bool = typer.Option(False, "--float64", help="store per-epoch series as float64 (default float32)"),
    epoch_states: int = typer.Option(None, "--epoch-states", min=0, help="also write states.parquet: per-epoch "
                                     "estimate, error and sigma (model axes and RIC) of runs 0..N-1 (overrides "
                                     "output.epoch_states_runs; docs/outputs.md)"),
    quiet: QuietOption = False,
    as_json: bool = json_option(),
):
    """Run a scenario's Monte Carlo campaign (EKF, or batch least squares) and write Parquet results. While it
    compiles (a first run), a second process compiles on the idle core what `liaison errors` and
    `liaison observability` need for the scenario; --jobs 1 keeps it to one process.

    Example: liaison run scenarios/eml2_lunar.yaml --runs 20 --jobs 2 --epoch-states 5"""
    from liaison_cli.campaign.engine.ahead import compiling_ahead
    from liaison_cli.campaign.engine.results import stream_campaign
    from liaison_cli.campaign.studies.output import fill_folder
    from liaison_cli.scenario.loading import load_scenario

    check_runs(runs)
    where = fan_out(backend, scheduler, scheduler_timeout)
    started = time.perf_counter()
    config, text = load_scenario(scenario)
    if epoch_states is not None:
        from liaison_cli.scenario.loading import apply_overrides

        config = apply_overrides(config, {"output.epoch_states_runs": epoch_states}, "--epoch-states")
    log.info("read and checked %s in %.2f s", scenario, time.perf_counter() - started)
    out_dir = output or Path("results") / config.name
    if output is None and not overwrite and _earlier_run_of(out_dir, config.name):  # an edit-and-rerun cycle
        overwrite = True
        log.warning("replacing %s (an earlier `liaison run` of %s; --output keeps both)", out_dir, config.name)
    with compiling_ahead(config, jobs, where.name):  # on a cache miss, `errors`' kernels on the idle core
        problem, summary = fill_folder(out_dir, overwrite, lambda stage: stream_campaign(  # complete, or not at all
            config, stage, text, runs=runs, jobs=jobs, progress=not quiet and sys.stderr.isatty(),
            float_dtype="float64" if float64 else "float32", where=where))
    if as_json:
        from liaison_cli.report.json_summary import run_document

        echo_json(run_document(config, scenario, problem, summary, out_dir))
    else:
        _print_run(config, problem, summary, out_dir)
    if not any(row["status"] == "ok" for row in summary):
        fail(f"no run of {config.name} finished healthy (see the "
             f"{'failed_runs' if as_json else 'status line above'}); results kept in {out_dir}", EXIT_ALL_DIVERGED)


def _earlier_run_of(folder: Path, name: str) -> bool:
    """The folder is a `liaison run` result of a scenario named `name`: our marker, a run's timeseries, and a
    summary.parquet whose provenance names that scenario. Anything else (a study's or compare's folder, another
    scenario's run, a folder liaison did not write) is kept: replacing it needs --output and --overwrite."""
    from liaison_cli.storage.ownership import RESULT_MARKER
    from liaison_cli.storage.parquet import read_metadata

    if not ((folder / RESULT_MARKER).is_file() and (folder / "timeseries.parquet").is_file()):
        return False
    try:
        effective = read_metadata(folder / "summary.parquet").get("scenario_effective") or {}
    except Exception:  # noqa: BLE001 - unreadable provenance: not provably ours to replace
        return False
    return isinstance(effective, dict) and effective.get("name") == name


def _print_run(config, problem, summary: list[dict], out_dir: Path) -> None:
    span = (f"batch span {config.batch.span_days:g} d + {config.batch.prediction_hours:g} h"
            if config.batch is not None else f"{config.duration_days:g} d")
    typer.echo(
        f"{config.name}: {len(problem.spacecraft)} spacecraft, {len(config.links)} link(s), "
        f"sigma {problem.sigma_m:.1f} m, {span}, seed {config.monte_carlo.seed}"
    )
    for setting in _setting_lines(config, problem):
        typer.echo(setting)
    typer.echo(_format_summary(summary, problem.spacecraft))
    typer.echo(_format_consistency(summary, problem.spacecraft, config.settle_days()))
    from liaison_cli.campaign.advice import campaign_advice  # here: a tab press must not load numba (cli.root)

    advice = _format_advice(campaign_advice(config, summary, problem.spacecraft, CONSISTENCY_COLUMNS,
                                            problem.step_choices))
    if advice:
        typer.echo(advice)
    for optional in (_format_ric(summary, problem.spacecraft, config.settle_days()),
                     _format_smoothed(summary, problem.spacecraft), _format_prediction(summary, problem.spacecraft)):
        if optional:
            typer.echo(optional)
    typer.echo(_status_line(summary))
    rejections = _rejection_line(summary, config.filter)
    if rejections:
        typer.echo(rejections)
    for line in _coverage_lines(problem, config.duration_days):
        typer.echo(line)
    typer.echo(f"results: {out_dir}")


def _setting_lines(config, problem) -> list[str]:
    """The settings the tool chose for the scenario, with where each came from: the integration step and the
    default process noise."""
    from liaison_cli.scenario.default_noise import default_noise_line
    from liaison_cli.scenario.integration_steps import step_choice_line

    if config.batch is not None or not problem.step_choices:
        return []
    lines = [step_choice_line(problem.step_choices, config.measurement.interval_s,
                            config.filter.integration_tolerance_m)]
    if problem.default_noises:
        lines.append(default_noise_line(problem.default_noises))
    return lines


def _coverage_lines(problem, duration_days: float) -> list[str]:
    """The links that measure at a small share of the epochs (report.run_text.coverage_lines), from the
    scenario's data (its observed file's, when it reads one)."""
    import numpy as np

    from liaison_cli.report.run_text import coverage_lines, link_coverage

    values = problem.observed.values if problem.observed is not None else problem.measurements_true
    available = np.isfinite(values[1:])
    return coverage_lines(link_coverage(available, [ch.link_label for ch in problem.channels]), duration_days)


@app.command()
@user_errors
def table3(
    runs: int = typer.Option(10, "--runs", min=1, help="Monte Carlo runs per case"),
    jobs: JobsOption = 2,
    backend: BackendOption = "joblib",
    scheduler: SchedulerOption = None,
    scheduler_timeout: SchedulerTimeoutOption = 20.0,
    output: Path = typer.Option(Path("results/table3"), "--output", help="result folder"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder"),
    scenarios: Path = typer.Option(None, "--scenarios", help="folder holding the paper's scenario files "
                                   "(default: the shipped scenarios/, read from the installed package whatever "
                                   "the working folder)"),
    quiet: QuietOption = False,
    as_json: bool = json_option(),
):
    """Reproduce Turan et al. (2022) Table 3: 3 formations x 150/300 m, printed beside the paper.

    Example: liaison table3 --runs 10 --json"""
    from liaison_cli.campaign.studies.output import StudyOutput, write_folder
    from liaison_cli.campaign.studies.table3 import compute_table3, provenance
    from liaison_cli.report.table3 import to_markdown

    check_runs(runs)
    where = fan_out(backend, scheduler, scheduler_timeout)

    def make():
        computed = compute_table3(scenario_folder(scenarios), runs, jobs, not quiet and sys.stderr.isatty(), where)
        return StudyOutput({"table3": computed.table, "summary": computed.summaries}, provenance(computed, runs),
                           {"table3.md": to_markdown(computed.table, computed.checks)})

    written = write_folder(output, overwrite, make)
    if as_json:
        from liaison_cli.report.json_summary import study_document

        echo_json(study_document("table3", output, {"table3": written.tables["table3"]}, runs_per_case=runs,
                                 ordering_checks=written.meta["ordering_checks"]))
        return
    typer.echo(written.texts["table3.md"])
    typer.echo(f"results: {output}")


@app.command()
@user_errors
def compare(
    scenarios: list[Path] = typer.Argument(..., help="scenario YAML files to run side by side"),
    runs: int = typer.Option(None, "--runs", min=1, help="Monte Carlo runs per scenario (default: each scenario's)"),
    jobs: JobsOption = 2,
    backend: BackendOption = "joblib",
    scheduler: SchedulerOption = None,
    scheduler_timeout: SchedulerTimeoutOption = 20.0,
    output: Path = typer.Option(Path("results/compare"), "--output", help="result folder"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder"),
    quiet: QuietOption = False,
    as_json: bool = json_option(),
):
    """Run several scenarios; tabulate RMS errors averaged over each scenario's spacecraft (001 Tables 6-7).

    Example: liaison compare eml2_lunar eml1_lunar --runs 10"""
    from liaison_cli.campaign.studies.compare import compare_study, provenance
    from liaison_cli.campaign.studies.output import StudyOutput, write_folder
    from liaison_cli.report.compare import to_markdown
    from liaison_cli.scenario.loading import load_scenario

    check_runs(runs)
    where = fan_out(backend, scheduler, scheduler_timeout)
    loaded = [(path, *load_scenario(path)) for path in scenarios]
    refuse_repeated_labels([(path, config.name) for path, config, _ in loaded], "name")

    def make():
        table, summary, texts = compare_study(loaded, runs, jobs, not quiet and sys.stderr.isatty(), where)
        return StudyOutput({"compare": table, "summary": summary}, provenance(texts),
                           {"compare.md": to_markdown(table)}, result=table)

    written = write_folder(output, overwrite, make)
    table, markdown = written.result, written.texts["compare.md"]
    if as_json:
        from liaison_cli.report.json_summary import compare_document

        echo_json(compare_document(table, output))
        return
    typer.echo(markdown)
    typer.echo(f"results: {output}")
