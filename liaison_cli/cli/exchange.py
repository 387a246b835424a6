"""`liaison export`: one run of a result as CCSDS files (OEM per spacecraft, TDM of its measurements)."""

from pathlib import Path

import typer

from liaison_cli.cli.common import echo_json, fail, json_option, user_errors
from liaison_cli.cli.root import app


@app.command("export")
@user_errors
def export(
    result: Path = typer.Argument(..., help="a result folder of `liaison run`"),
    run_index: int = typer.Option(0, "--run", min=0, help="the run to export"),
    data_format: str = typer.Option("both", "--format", help="kvn, xml or both"),
    output: Path = typer.Option(None, "--output", help="folder (default: RESULT/ccsds-run<K>)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing export folder"),
    frame: str = typer.Option(None, "--frame", help="rotating (a CRTBP run's own frame, MET tags) or icrf (a "
                              "dated run's, and a CRTBP run's with --epoch) [default: the run's own]"),
    epoch: str = typer.Option(None, "--epoch", help="a CRTBP run's t0 as a TDB date, YYYY-MM-DDThh:mm:ss (with "
                              "--frame icrf: the CRTBP's axes are anchored to DE421's Moon then)"),
    centre: str = typer.Option("earth", "--centre", help="earth or moon: the ICRF origin of a CRTBP run's export"),
    as_json: bool = json_option(),
):
    """One run as CCSDS files: truth and estimate OEM (with covariance) per spacecraft, TDM of its measurements.

    Examples: liaison run eml2_lunar --runs 4; liaison export results/eml2_lunar --run 3 --format both;
    liaison export results/eml2_lunar --frame icrf --epoch 2030-01-01T00:00:00 --centre moon"""
    from liaison_cli.campaign.exchange.export import check_export_request, export_run
    from liaison_cli.campaign.studies.output import fill_folder

    request = _frame_request(frame, epoch, centre)

    formats = {"kvn": ("kvn",), "xml": ("xml",), "both": ("kvn", "xml")}.get(data_format)
    if formats is None:
        fail(f"--format {data_format!r}: allowed kvn, xml, both", 2)
    out_dir = output or result / f"ccsds-run{run_index}"
    check_export_request(result, out_dir)  # before any folder is made or any run redone
    done = fill_folder(out_dir, overwrite, lambda stage: export_run(result, run_index, formats, stage, request))
    if as_json:
        from liaison_cli.report.json_summary import export_document

        echo_json(export_document(done, out_dir))
        return
    typer.echo(f"{done['scenario']}: run {done['run']}, {done['epochs']} epochs recomputed (position errors within "
               f"{done['stored_difference_m']:.2g} m of the stored run)")
    for skipped in done["skipped"]:
        typer.echo(f"not in the TDM (no TDM keyword): {skipped}")
    typer.echo(f"{len(done['files'])} files: {out_dir}")



def _frame_request(frame: str | None, epoch: str | None, centre: str):
    """The FrameRequest of --frame, --epoch and --centre (checked against the run by export_frame)."""
    from liaison_cli.campaign.exchange.export import FrameRequest, parse_epoch

    if frame not in (None, "rotating", "icrf"):
        fail(f"--frame {frame!r}: allowed rotating, icrf", 2)
    if centre not in ("earth", "moon"):
        fail(f"--centre {centre!r}: allowed earth, moon", 2)
    seconds, text = parse_epoch(epoch) if epoch is not None else (None, None)
    return FrameRequest(frame, seconds, text, centre.upper())
