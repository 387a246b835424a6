"""`liaison plot ...`: figures from result folders (PNG + SVG)."""

from pathlib import Path

import typer

from liaison_cli.cli.common import user_errors
from liaison_cli.cli.root import app

plot_app = typer.Typer(no_args_is_help=True, help="Figures from result folders (PNG + SVG).")
app.add_typer(plot_app, name="plot")


@plot_app.command("fig15")
@user_errors
def plot_fig15(
    sweep_dir: Path = typer.Argument(..., help="folder written by 'liaison sweep --sigma ...'"),
    output: Path = typer.Option(None, "--output", help="file stem for .png/.svg (default: SWEEP_DIR/fig15)"),
    title: str = typer.Option(None, "--title", help="figure title"),
):
    """Error vs ranging sigma (Fig. 15), one line per formation and spacecraft, Table 3 overlaid.

    Example: liaison sweep --sigma 50:700 --runs 10; liaison plot fig15 results/sweep-fig15"""
    from liaison_cli.campaign.studies.table3 import paper_table3
    from liaison_cli.report.fig15 import draw_fig15, load_curve, paper_points_vs_curve

    curve, paper = load_curve(sweep_dir), paper_table3()
    paths = draw_fig15(curve, paper, output or sweep_dir / "fig15", title)
    check = paper_points_vs_curve(curve, paper)
    if len(check):
        typer.echo("Turan et al. 2022 Table 3 against our curve (mean of run RMS, interpolated in sigma):")
        for row in check.itertuples():
            scale, unit = (1.0, "m") if row.metric == "rms_position_m" else (1e3, "mm/s")
            typer.echo(f"  {row.scenario:<11}{row.spacecraft:<7}{row.sigma_m:>5.0f} m  {row.metric[4:12]:<9}"
                       f"ours {scale * row.ours:9.2f} {unit:<5} paper {scale * row.paper:9.2f} {unit:<5}"
                       f"ratio {row.ratio:5.2f}")
    for path in paths:
        typer.echo(f"wrote {path}")


@plot_app.command("run")
@user_errors
def plot_run(
    result_dir: Path = typer.Argument(..., metavar="RESULT_DIR", help="folder written by 'liaison run'"),
    output: Path = typer.Option(None, "--output", help="folder for the figures (default: RESULT_DIR/plots)"),
    run: int = typer.Option(None, "--run", min=0, help="run to highlight (default: the first that finished ok)"),
):
    """A run result's errors against 3σ, NEES against its 95 % band, normalised innovations, clocks and biases.

    Example: liaison run eml2_lunar --runs 4; liaison plot run results/eml2_lunar"""
    from liaison_cli.report.run_plots import draw_run
    from liaison_cli.report.run_result import highlighted_run, load_run_result

    result = load_run_result(result_dir)
    paths = draw_run(result, output or result_dir / "plots", highlighted_run(result, run))
    for path in paths:
        typer.echo(f"wrote {path}")
