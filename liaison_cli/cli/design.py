"""`liaison design`: rank an open spacecraft's candidate orbits by covariance analysis, verify the best by Monte
Carlo (campaign.studies.design)."""

from pathlib import Path

import typer

from liaison_cli.cli import common
from liaison_cli.cli.common import user_errors
from liaison_cli.cli.root import app


@app.command("design")
@user_errors
def design(
    scenario_path: Path = typer.Argument(..., metavar="SCENARIO", help="the base scenario YAML (estimator: ekf)"),
    open_spacecraft: str = typer.Option(None, "--open", metavar="NAME", help="the spacecraft whose orbit is open"),
    family: str = typer.Option(None, "--family", metavar="FAMILY", help="its candidates' orbit family "
                               "(`liaison orbits list`)"),
    periods: str = typer.Option(None, "--periods", metavar="LOW:HIGH:COUNT", help="COUNT periods evenly spaced "
                                "from LOW to HIGH days"),
    vary: list[str] = typer.Option(None, "--vary", metavar="KEY=V1,V2,...", help="another factor of the "
                                   "candidates: any scenario value by dotted path (may repeat; full factorial with "
                                   "the family's members), e.g. spacecraft.1.elements.altitude_km=50,100,200"),
    choices_file: Path = typer.Option(None, "--choices", metavar="FILE", help="labelled options, each setting "
                                      "several scenario values at once (a whole spacecraft, a topology, a link), "
                                      "as YAML: {factor: {label: {dotted.key: value, ...}, ...}, ...}; full "
                                      "factorial with the other factors"),
    phases: int = typer.Option(1, "--phases", min=1, help="phases along each orbit: 0, 1/N, ..."),
    objective: str = typer.Option("worst", "--objective", metavar="NAME", help="the spacecraft whose position "
                                  "error RMS after the settle time is minimised, worst (the largest of them), "
                                  "mean (their mean), or condition (the range information matrix's condition number; implies "
                                  "--condition)"),
    converge_below: float = typer.Option(None, "--converge-below", metavar="METRES", help="rank by the day the "
                                         "objective's LinCov position error falls below METRES and stays there "
                                         "(ties by the RMS)"),
    top: int = typer.Option(3, "--verify", min=0, help="verify the best N by Monte Carlo (0: none)"),
    condition: bool = typer.Option(False, "--condition", help="also each candidate's range information condition "
                                   "number (liaison observability's; about 0.5 s per spacecraft of a 10-day "
                                   "formation, several times the LinCov score)"),
    runs: int = typer.Option(30, "--runs", min=2, help="Monte Carlo runs per verified candidate"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/<name>-design)"),
    work: Path = typer.Option(None, "--work", help="folder of the finished candidates, so that an interrupted "
                              "search resumes (default: the output folder's name + .work, beside it)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an earlier design there"),
    jobs: common.JobsOption = 2,
    backend: common.BackendOption = "joblib",
    scheduler: common.SchedulerOption = None,
    scheduler_timeout: common.SchedulerTimeoutOption = 20.0,
    as_json: bool = common.json_option(),
):
    """Which orbit should a spacecraft fly? Score every candidate by LinCov, rank, verify the best by Monte Carlo.

    Examples: liaison design eml2_lunar --open EML2 --family l2_halo_south --periods 9:14:6 --phases 4
    --objective Lunar --verify 3 --runs 30; liaison design eml2_lunar --vary spacecraft.1.elements.a_km=6000,9000,12000
    --vary spacecraft.1.elements.i_deg=30,60,90 --objective Lunar --output results/eml2_lunar-orbiter-design"""
    from liaison_cli.campaign.studies.budget_tables import provenance
    from liaison_cli.campaign.studies.design import make_design, read_choices, score_all, verify
    from liaison_cli.campaign.studies.output import write_folder
    from liaison_cli.campaign.sweep.grid import parse_grid
    from liaison_cli.scenario.loading import read_scenario_text, scenario_file, validate_scenario

    where = common.fan_out(backend, scheduler, scheduler_timeout)
    scenario_path = scenario_file(scenario_path)
    data, text = read_scenario_text(scenario_path)
    base = validate_scenario(data, str(scenario_path))  # the base itself must be a valid scenario
    factors = [parse_grid(given) for given in vary or []]
    choices = read_choices(choices_file) if choices_file is not None else []
    plan = make_design(data, open_spacecraft, objective, family, periods, phases, condition, factors, choices,
                       converge_below)
    out_dir = output or Path("results") / f"{base.name}-design"
    columns = [factor for factor, _ in choices] + [key for key, _ in factors]
    varied = ", ".join([f"{open_spacecraft} on {family}"] * bool(family) + columns)
    if not as_json:
        typer.echo(f"{base.name}: {len(plan.candidates)} candidates ({varied}), ranked by "
                   f"{_ranked_by(objective, base.settle_days(), converge_below)}")

    title = f"{base.name}: {varied}, objective {objective}"

    def make():
        table = verify(plan, score_all(plan, jobs, where, work or out_dir.parent / f"{out_dir.name}.work"), top,
                       runs, jobs, where)
        return _design_output(table, objective, columns, top, converge_below, title, provenance(base.name, text))

    text, table, rho, by_condition = write_folder(out_dir, overwrite, make).result
    if as_json:
        from liaison_cli.report.json_summary import design_document

        common.echo_json(design_document(base.name, open_spacecraft, family, objective, table, out_dir, rho,
                                         by_condition, factors=columns, converge_below_m=converge_below))
        return
    typer.echo(text, nl=False)
    typer.echo(f"results: {out_dir}")


def _design_output(table, objective: str, columns, top: int, converge_below, title: str, provenance: dict):
    """The result folder's contents (StudyOutput) for a scored and verified candidate table: the table, the
    ranking with its agreement lines, the figures; and (text, table, rho, condition rho) for the command."""
    from liaison_cli.campaign.studies.design import condition_agreement, rank_agreement
    from liaison_cli.campaign.studies.output import StudyOutput
    from liaison_cli.report.design import draw_pareto, draw_score_plane, format_agreement, format_ranking

    rho, by_condition = rank_agreement(table), condition_agreement(table)
    text = (format_ranking(table, objective, factors=columns, converge_below_m=converge_below)
            + format_agreement(rho, top, by_condition))
    method = "LinCov along the truth (every error source) per candidate; the best verified by Monte Carlo"
    return StudyOutput({"candidates": table}, {**provenance, "method": method}, {"ranking.md": text},
                       lambda folder: [path for path in (draw_score_plane(table, folder / "design.png", title),
                                                         draw_pareto(table, folder / "pareto.png", title))
                                       if path is not None],
                       result=(text, table, rho, by_condition))


def _ranked_by(objective: str, settle_days: float, converge_below_m: float | None) -> str:
    """What the candidates are ranked by, in words (the command's first line)."""
    if converge_below_m is not None:
        return (f"the day LinCov's {objective} position error falls below {converge_below_m:g} m and stays (ties by "
                f"its RMS after {settle_days:g} d)")
    if objective == "condition":
        return "the range information condition number (LinCov's worst position error RMS beside it)"
    return f"LinCov on {objective}'s position error RMS after {settle_days:g} d"
