"""`liaison observability` and `liaison geometry`: information-matrix studies without Monte Carlo."""

from pathlib import Path

import typer

from liaison_cli.cli.common import echo_json, json_option, user_errors
from liaison_cli.cli.root import app


@app.command()
@user_errors
def observability(
    scenario: Path = typer.Argument(..., help="scenario YAML file"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/observability-<name>)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder"),
    range_rate_sigma_m_s: float = typer.Option(
        None, "--range-rate-sigma", min=1e-9,
        help="range-rate 1-sigma in m/s for the range-rate weights [default: the scenario's, else 0.001]"),
    no_taylor: bool = typer.Option(False, "--no-taylor", help="skip the Taylor-series STM comparison"),
    as_json: bool = json_option(),
):
    """Information matrix, SVD, condition number, unobservability index and effectiveness (no a-priori).

    Example: liaison observability scenarios/eml2_lunar.yaml --no-taylor"""
    from liaison_cli.campaign.studies.observability_study import (check_supported, observability_study, provenance,
                                                                  study_tables)
    from liaison_cli.campaign.studies.output import StudyOutput, write_folder
    from liaison_cli.report.observability_report import draw_effectiveness, summary_json
    from liaison_cli.scenario.loading import load_scenario

    config, text = load_scenario(scenario)
    check_supported(config, str(scenario))
    if range_rate_sigma_m_s is None:
        range_rate_sigma_m_s = config.noise.resolved_range_rate_sigma_m_s() or 1e-3
    out_dir = output or Path("results") / f"observability-{config.name}"

    def make():
        study = observability_study(config, range_rate_sigma_m_s, taylor=not no_taylor)
        return StudyOutput(study_tables(study), provenance(study, text),
                           {"observability.json": summary_json(study.summary)},
                           lambda folder: draw_effectiveness(study, folder / "effectiveness.png", config.name),
                           result=study.summary)

    summary = write_folder(out_dir, overwrite, make).result
    if as_json:
        from liaison_cli.report.json_summary import observability_document

        echo_json(observability_document(summary, out_dir))
        return
    for observable, values in summary["observables"].items():
        least = ", ".join(f"{label} {weight:+.2f}" for label, weight in values["least_observable"])
        most = ", ".join(f"{label} {weight:+.2f}" for label, weight in values["most_observable"])
        typer.echo(f"{observable:<11} condition number {values['condition_number']:.3e}   unobservability index "
                   f"{values['unobservability_index']:.3e}")
        typer.echo(f"{'':<11} most observable: {most}; least observable: {least}")
    for row in summary["gamma_range_rate_over_range"]:
        typer.echo(f"gamma (range-rate / range information), {row['spacecraft']:<8} position: median "
                   f"{row['gamma_position_median']:.3g}, >= 1 at {100 * row['share_epochs_gamma_position_ge_1']:.0f} % "
                   f"of epochs; velocity: median {row['gamma_velocity_median']:.3g}, >= 1 at "
                   f"{100 * row['share_epochs_gamma_velocity_ge_1']:.0f} %")
    for row in summary.get("taylor_stm", []):
        typer.echo(f"Taylor STM vs integrated, {row['spacecraft']:<8} step {row['step_s']:>4} s: relative error "
                   f"RMS {row['relative_error_rms']:.2e}, std {row['relative_error_std']:.2e}")
    typer.echo(f"results: {out_dir}")


@app.command()
@user_errors
def geometry(
    output: Path = typer.Option(Path("results/geometry"), "--output", help="result folder"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder"),
    count: int = typer.Option(7, "--count", min=2, max=30, help="orbits per family"),
    interval_s: float = typer.Option(600.0, "--interval", min=10.0, help="sampling interval of the links, s"),
    as_json: bool = json_option(),
):
    """Formation-geometry study: condition number of every L1 x L2 halo pair and L2 halo x lunar orbiter.

    Example: liaison geometry --count 5 --json"""
    from liaison_cli.campaign.studies.geometry import GRIDS, geometry_tables, provenance
    from liaison_cli.campaign.studies.output import StudyOutput, write_folder
    from liaison_cli.report.geometry import draw_study

    out_dir = output

    def make():
        tables = geometry_tables(count, interval_s)
        titles = {key: title for key, (_, _, title) in GRIDS.items()}
        return StudyOutput(tables, provenance(count, interval_s), draw=lambda folder: draw_study(
            tables, titles, interval_s, folder), table_meta={key: {"study": key} for key in tables}, result=tables)

    tables = write_folder(out_dir, overwrite, make).result
    if as_json:
        from liaison_cli.report.json_summary import study_document

        echo_json(study_document("geometry", out_dir, tables, count=count, interval_s=interval_s))
        return
    for key, table in tables.items():
        for observable in ("range", "range_rate"):
            col = table[f"{observable}_condition_number"]
            best, worst = table.loc[col.idxmin()], table.loc[col.idxmax()]
            typer.echo(f"{key:<14}{observable:<11} cond {col.min():.2e} ({best['first']} / {best['second']}) to "
                       f"{col.max():.2e} ({worst['first']} / {worst['second']})")
    typer.echo(f"results: {out_dir}")
