"""`liaison errors`: the EKF's error split by source (LinCov), with an optional Monte Carlo check."""

import sys
from pathlib import Path

import typer

from liaison_cli.cli import common
from liaison_cli.cli.common import echo_json, json_option, user_errors
from liaison_cli.cli.root import app


@app.command("errors")
@user_errors
def errors(
    scenario_path: Path = typer.Argument(..., metavar="SCENARIO", help="scenario YAML (estimator: ekf)"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/<name>-errors)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an earlier error budget there"),
    sources: str = typer.Option(None, "--sources", help="comma list of sources to check by Monte Carlo "
                                "(initial, noise, process, bias, measurement_model, dynamics_model)"),
    check_runs: int = typer.Option(0, "--check-runs", min=0, help="Monte Carlo runs for the check (0: none)"),
    jobs: common.JobsOption = 2,
    backend: common.BackendOption = "joblib",
    scheduler: common.SchedulerOption = None,
    scheduler_timeout: common.SchedulerTimeoutOption = 20.0,
    quiet: common.QuietOption = False,
    as_json: bool = json_option(),
):
    """Error budget: the EKF's error split by source (LinCov along the truth) and its consistency after the
    settle time (budget error RMS / filter sigma RMS), with an optional MC check (adds the NEES-in-band share).

    Example: liaison errors eml2_lunar --check-runs 20"""
    from liaison_cli.campaign.studies.budget_tables import budget_tables, by_source, provenance
    from liaison_cli.campaign.studies.error_budget import budget_study, select_sources
    from liaison_cli.campaign.studies.output import StudyOutput, write_folder
    from liaison_cli.report.error_budget import draw_budget, format_budget_consistency, format_shares
    from liaison_cli.scenario.loading import read_scenario_text, scenario_file, validate_scenario
    from liaison_cli.campaign.engine.noise_check import prepare_checked_problem
    from liaison_cli.scenario.default_noise import default_noise_line

    common.check_runs(check_runs, "--check-runs")
    # The scheduler is asked only when the check will use it; a wrong backend is refused either way.
    where = common.fan_out(backend, scheduler, scheduler_timeout, connect=check_runs > 0)
    chosen = select_sources(sources)
    scenario_path = scenario_file(scenario_path)  # or the shipped scenario its name stands for
    data, text = read_scenario_text(scenario_path)
    scenario = validate_scenario(data, str(scenario_path))  # the filter `run` would build, defaults included
    progress = not quiet and not as_json and sys.stderr.isatty()
    problem = prepare_checked_problem(scenario)  # the default noise as `run` flies it, LinCov-checked
    study = budget_study(problem, chosen, check_runs, jobs, where, progress)
    table = format_shares(study.rows_all, study.rows_late)
    consistency_text = format_budget_consistency(study.consistency_rows, scenario.settle_days(), study.nees_share,
                                          check_runs)
    if not as_json:
        if problem.default_noises:  # the same line as `run`'s: where the budget's process noise came from
            typer.echo(default_noise_line(problem.default_noises))
        _print_budget(scenario, table, study.checks, check_runs)
        typer.echo(consistency_text, nl=False)
    out_dir = output or Path("results") / f"{scenario.name}-errors"
    write_folder(out_dir, overwrite, lambda: StudyOutput(
        budget_tables(study), provenance(scenario.name, text), {"shares.md": table + "\n" + consistency_text},
        lambda folder: [draw_budget(study.budget, by_source(study.budget), folder / "error_budget.png",
                                    f"Error budget: {scenario.name}")]))
    if as_json:
        from liaison_cli.report.json_summary import errors_document

        echo_json(errors_document(scenario, out_dir, study.rows_all, study.rows_late, study.checks))
    else:
        typer.echo(f"results: {out_dir}")


def _print_budget(scenario, table: str, checks: list[dict], check_runs: int) -> None:
    typer.echo(f"{scenario.name}: share of the mean-square error by source (LinCov along the truth, "
               f"{scenario.duration_days:g} d)")
    typer.echo(table, nl=False)
    if checks:
        typer.echo(f"Monte Carlo ({check_runs} runs of the EKF) over LinCov, mean-square error after t0 "
                   "(± its Monte Carlo standard error):")
        for row in checks:
            typer.echo(f"  {row['sources']:<32}{row['spacecraft']:<10}{row['quantity']:<10}"
                       f"{row['monte_carlo_over_lincov']:8.3f} ± {row['monte_carlo_over_lincov_standard_error']:.3f}")
