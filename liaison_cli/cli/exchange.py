"""`liaison export`: one run of a result as CCSDS files (OEM per spacecraft, TDM of its measurements)."""

from pathlib import Path

import typer

from liaison_cli.cli.common import fail, user_errors
from liaison_cli.cli.root import app


@app.command("export")
@user_errors
def export(
    result: Path = typer.Argument(..., help="a result folder of `liaison run`"),
    run_index: int = typer.Option(0, "--run", min=0, help="the run to export"),
    data_format: str = typer.Option("both", "--format", help="kvn, xml or both"),
    output: Path = typer.Option(None, "--output", help="folder (default: RESULT/ccsds-run<K>)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing export folder"),
):
    """One run as CCSDS files: truth and estimate OEM (with covariance) per spacecraft, TDM of its measurements.

    Example: liaison export results/eml2_lunar --run 3 --format both"""
    from liaison_cli.campaign.exchange.export import export_run
    from liaison_cli.campaign.studies.output import fill_folder

    formats = {"kvn": ("kvn",), "xml": ("xml",), "both": ("kvn", "xml")}.get(data_format)
    if formats is None:
        fail(f"--format {data_format!r}: allowed kvn, xml, both", 2)
    out_dir = output or result / f"ccsds-run{run_index}"
    if Path(out_dir).resolve() in (Path(result).resolve(), *Path(result).resolve().parents):
        fail(f"--output {out_dir}: the result folder being exported, or a folder holding it; allowed: a folder "
             f"beside or inside it (default: {result / f'ccsds-run{run_index}'})", 2)
    done = fill_folder(out_dir, overwrite, lambda stage: export_run(result, run_index, formats, stage))
    typer.echo(f"{done['scenario']}: run {done['run']}, {done['epochs']} epochs recomputed (position errors within "
               f"{done['stored_difference_m']:.2g} m of the stored run)")
    for skipped in done["skipped"]:
        typer.echo(f"not in the TDM (no TDM keyword): {skipped}")
    typer.echo(f"{len(done['files'])} files: {out_dir}")
