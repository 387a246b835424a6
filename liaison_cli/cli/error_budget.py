"""`liaison errors`: the EKF's error split by source (LinCov), with an optional Monte Carlo check."""

import sys
from pathlib import Path

import typer

from liaison_cli.cli import common
from liaison_cli.cli.common import echo_json, json_option, user_errors
from liaison_cli.cli.root import app
from liaison_cli.errors import LiaisonError


@app.command("errors")
@user_errors
def errors(
    scenario_path: Path = typer.Argument(..., metavar="SCENARIO", help="scenario YAML (estimator: ekf)"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/<name>-errors)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an earlier error budget there"),
    sources: str = typer.Option(None, "--sources", help="comma list of sources to check by Monte Carlo "
                                "(initial, noise, process, bias, measurement_model, dynamics_model)"),
    check_runs: int = typer.Option(0, "--check-runs", min=0, help="Monte Carlo runs for the check (0: none)"),
    jobs: int = common.jobs_option(),
    backend: str = common.backend_option(),
    scheduler: str = common.scheduler_option(),
    scheduler_timeout: float = common.scheduler_timeout_option(),
    quiet: common.QuietOption = False,
    as_json: bool = json_option(),
):
    """Error budget: the EKF's error split by source (LinCov along the truth) and its consistency after the
    settle time (budget error RMS / filter sigma RMS), with an optional MC check (adds the NEES-in-band share)."""
    import pandas as pd

    from liaison_cli.campaign.error_budget import (SOURCES, consistency, error_budget, monte_carlo_check, part_of,
                                                   select_sources, shares)
    from liaison_cli.dynamics.constants import SECONDS_PER_DAY
    from liaison_cli.report.error_budget import (budget_table, draw_budget, format_consistency, format_shares,
                                                 shares_frame)
    from liaison_cli.scenario.schema import read_scenario_text, validate_scenario
    from liaison_cli.scenario.setup import prepare_problem
    from liaison_cli.storage import staged_output, write_parquet_atomic, write_text_atomic

    common.check_runs(check_runs, "--check-runs")
    where = common.fan_out(backend, scheduler, scheduler_timeout)
    chosen = select_sources(sources)
    data, text = read_scenario_text(scenario_path)
    if isinstance(data, dict) and "filter" not in data:
        raise LiaisonError(f"{scenario_path}: key 'filter' is missing: the error budget splits the filter's own "
                           "error, so give its settings (a 'filter' section)")
    scenario = validate_scenario(data, str(scenario_path))
    problem = prepare_problem(scenario)
    budget = error_budget(problem)
    rows_all, rows_late = shares(budget), shares(budget, SECONDS_PER_DAY)
    table = format_shares(rows_all, rows_late)
    settle_s = scenario.settle_days() * SECONDS_PER_DAY
    progress = not quiet and not as_json and sys.stderr.isatty()
    checks = (monte_carlo_check(problem, budget, check_runs, chosen, settle_s, jobs, where, progress)
              if check_runs else [])
    consistency_rows = consistency(budget, settle_s)
    nees_share = checks[0]["nees_in_band_share_settled"] if checks and chosen == SOURCES else None
    for row in consistency_rows:
        row["nees_in_band_share_settled"] = float("nan") if nees_share is None else nees_share
    consistency_text = format_consistency(consistency_rows, scenario.settle_days(), nees_share, check_runs)
    if not as_json:
        _print_budget(scenario, table, checks, check_runs)
        typer.echo(consistency_text, nl=False)
    meta = {"package": "liaison", "scenario": scenario.name, "scenario_yaml": text,
            "method": "LinCov along the truth with the filter's own gains; parts in m^2 and (m/s)^2"}
    out_dir = output or Path("results") / f"{scenario.name}-errors"
    with staged_output(out_dir, overwrite) as stage:
        write_parquet_atomic(budget_table(budget, part_of), stage / "budget.parquet", meta)
        write_parquet_atomic(shares_frame(rows_all, rows_late), stage / "shares.parquet", meta)
        if checks:
            write_parquet_atomic(shares_frame(checks), stage / "monte_carlo_check.parquet", meta)
        write_parquet_atomic(pd.DataFrame(consistency_rows), stage / "consistency.parquet", meta)
        write_text_atomic(table + "\n" + consistency_text, stage / "shares.md")
        draw_budget(budget, part_of, stage / "error_budget.png", f"Error budget: {scenario.name}")
    if as_json:
        from liaison_cli.report.json_summary import errors_document

        echo_json(errors_document(scenario, out_dir, rows_all, rows_late, checks))
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
