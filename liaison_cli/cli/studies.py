"""The papers' studies: `liaison study003`, `liaison study004` and `liaison tables002`."""

import sys
from pathlib import Path

import typer

from liaison_cli.cli.common import (
    BackendOption,
    JobsOption,
    QuietOption,
    SchedulerOption,
    SchedulerTimeoutOption,
    StudyGridOption,
    StudyOverwriteOption,
    check_runs,
    echo_json,
    fan_out,
    json_option,
    refuse_repeated_labels,
    user_errors,
)
from liaison_cli.cli.root import app
from liaison_cli.errors import LiaisonError
from liaison_cli.scenario.shipped import scenario_paths


def _load_study(paths: list[Path]) -> list:
    """[(name = file stem, scenario, text)] of a study's scenario files. The stem labels the study's rows,
    metadata and figures, so two files with one stem would be merged into one label: refused."""
    from liaison_cli.scenario.loading import load_scenario

    refuse_repeated_labels([(Path(path), Path(path).stem) for path in paths], "file stem")
    return [(Path(path).stem, *load_scenario(path)) for path in paths]


def work_option():
    return typer.Option(None, "--work", help="folder of the finished cells, so that an interrupted study resumes "
                                             "(default: the output folder's name + .work, beside it)")


def _work_folder(work: Path | None, output: Path) -> Path:
    return work if work is not None else output.parent / f"{output.name}.work"


# Defaults: shipped scenarios (scenario.shipped), the installed package's copies, from any working folder.
STUDY003_MISSIONS = ("003/cassini.yaml", "003/mer_a.yaml", "003/msl.yaml")


@app.command("study003")
@user_errors
def study003(
    scenarios: list[Path] = typer.Argument(None, metavar="[SCENARIO]...", help="missions' full-set scenarios "
                                           "(default: the shipped scenarios/003/cassini, mer_a, msl, read from "
                                           "the installed package whatever the working folder)"),
    runs: int = typer.Option(50, "--runs", min=1, help="Monte Carlo runs per mission and case"),
    jobs: JobsOption = 2,
    backend: BackendOption = "joblib",
    scheduler: SchedulerOption = None,
    scheduler_timeout: SchedulerTimeoutOption = 20.0,
    output: Path = typer.Option(Path("results/study003"), "--output", help="result folder"),
    overwrite: StudyOverwriteOption = False,
    work: Path = work_option(),
    grid: StudyGridOption = None,
    dsn_noise: str = typer.Option(None, "--dsn-noise", help="set every ground link's noise to one of 003's "
                                  "readings: table2 (10 m, 0.5 mm/s) or text (1 m, 0.1 mm/s); default: the files'"),
    quiet: QuietOption = False,
    as_json: bool = json_option(),
):
    """003's study: each departure mission x (DSN + LiAISON, DSN only, LiAISON only); 3D RMS table, figures.

    Example: liaison study003 --runs 50 --grid filter.underweighting=0,0.2"""
    from liaison_cli.campaign.sweep.grid import check_grid_size, parse_grid
    from liaison_cli.campaign.studies.output import StudyOutput, study_meta, write_folder
    from liaison_cli.campaign.studies.study003 import DSN_NOISE_READINGS, run_study, tuning
    from liaison_cli.campaign.studies.study_cells import first_grid_point
    from liaison_cli.report.study003 import draw_comparison, draw_mission, format_table

    check_runs(runs)
    where = fan_out(backend, scheduler, scheduler_timeout)
    if dsn_noise is not None and dsn_noise not in DSN_NOISE_READINGS:
        raise LiaisonError(f"--dsn-noise {dsn_noise!r}: allowed: {', '.join(DSN_NOISE_READINGS)}")
    axes = [parse_grid(text) for text in grid or []]
    check_grid_size(axes, 1, runs)
    loaded = _load_study(scenario_paths(scenarios, STUDY003_MISSIONS))
    progress = not quiet and sys.stderr.isatty()  # bars on a terminal only, never into a log
    summary, history, _ = run_study([(name, scenario) for name, scenario, _ in loaded], runs, jobs, progress,
                                    grid=axes, dsn_noise=dsn_noise, where=where, work=_work_folder(work, output))
    first = loaded[0][1]
    noise = (f"003 {dsn_noise} {DSN_NOISE_READINGS[dsn_noise]}" if dsn_noise else "as in the scenario files")
    heading = (f"003 study, {runs} runs per case, DSN noise: {noise}; "
               f"3D RMS after t0 (σ: the filter's; 003: its stated full-set values). Filter ({first.name}): "
               f"{tuning(first)}" + (f"; grid over {', '.join(k for k, _ in axes)}" if axes else ""))

    def draw(folder):  # the figures show the first grid point; every point's numbers are in the tables
        shown = first_grid_point(history, axes)
        for name, _, _ in loaded:
            draw_mission(shown, name, folder)
        draw_comparison(shown, folder)

    table = format_table(summary, [k for k, _ in axes], first.settle_days())
    write_folder(output, overwrite, lambda: StudyOutput({"summary": summary, "histories": history},
                                                        study_meta(loaded, runs), {"table.md": table}, draw))
    if as_json:
        from liaison_cli.report.json_summary import study_document

        echo_json(study_document("study003", output, {"summary": summary}, runs=runs, dsn_noise=dsn_noise,
                                 grid_keys=[k for k, _ in axes]))
        return
    typer.echo(heading)
    typer.echo(table, nl=False)
    typer.echo(f"results: {output}")


STUDY004_TRANSMITTERS = ("004/eml2_halo.yaml", "004/dro.yaml", "004/low_energy_transfer.yaml")


@app.command("study004")
@user_errors
def study004(
    scenarios: list[Path] = typer.Argument(None, metavar="[SCENARIO]...", help="transmitter scenarios, one link "
                                           "per receiver pair (default: the shipped scenarios/004/eml2_halo, "
                                           "dro, low_energy_transfer, read from the installed package "
                                           "whatever the working folder)"),
    runs: int = typer.Option(10, "--runs", min=1, help="Monte Carlo runs per transmitter and pair"),
    jobs: JobsOption = 2,
    backend: BackendOption = "joblib",
    scheduler: SchedulerOption = None,
    scheduler_timeout: SchedulerTimeoutOption = 20.0,
    output: Path = typer.Option(Path("results/study004"), "--output", help="result folder"),
    overwrite: StudyOverwriteOption = False,
    work: Path = work_option(),
    grid: StudyGridOption = None,
    quiet: QuietOption = False,
    as_json: bool = json_option(),
):
    """004's study: each transmitter x receiver pair (TDoA + FDoA); LinCov 3σ and the EKF Monte Carlo
    (converged share, time to converge, consistency), rankings, DOP, and 004's claims checked on the EKF's
    settled error with LinCov σ beside it (claims.parquet); table and figures.

    Example: liaison study004 --runs 10"""
    from liaison_cli.campaign.sweep.grid import check_grid_size, parse_grid
    from liaison_cli.campaign.studies.study003 import tuning
    from liaison_cli.campaign.studies.output import StudyOutput, study_meta, write_folder
    from liaison_cli.campaign.studies.study004 import check_claims, rankings, run_study
    from liaison_cli.campaign.studies.study_cells import first_grid_point
    from liaison_cli.report.study004 import (draw_histories, format_claims, format_rankings, format_table,
                                             initial_batch_text)

    check_runs(runs)
    where = fan_out(backend, scheduler, scheduler_timeout)
    axes = [parse_grid(text) for text in grid or []]
    check_grid_size(axes, 1, runs)
    keys = [k for k, _ in axes]
    loaded = _load_study(scenario_paths(scenarios, STUDY004_TRANSMITTERS))
    progress = not quiet and sys.stderr.isatty()  # bars on a terminal only, never into a log
    summary, history = run_study([(name, scenario) for name, scenario, _ in loaded], runs, jobs, progress,
                                 grid=axes, where=where, work=_work_folder(work, output))
    header = [f"004 study, {runs} runs per case. LinCov: steady state = median 3σ over the last quarter; converged "
              "= 3σ position below twice it from then on. EKF: a run converged when its position error stays below "
              "twice LinCov's steady 3σ (not before its initial batch hands over); steady state and convergence are "
              "judged before a manoeuvre where there is one; settled = after each "
              "scenario's settle time; consistent = the consistency verdict (analysis.consistency: the NEES test "
              "and the error/σ ratio's 95 % interval against [0.67, 1.5]; summary.parquet: "
              "ekf_consistency_failed)."]
    header += [f"Filter ({name}): {tuning(scenario)}{initial_batch_text(scenario)}" for name, scenario, _ in loaded]
    header.append("Written by `liaison study004 " + " ".join([*map(str, scenarios or []), f"--runs {runs}"]
                                                            + [f"--grid {text}" for text in grid or []]) + "`")
    if axes:
        header.append(f"Grid over {', '.join(keys)} (overrides the files' values)")
    claims = check_claims(summary, keys)
    table = "\n".join(header) + "\n\n" + format_table(summary, keys) + "\n" + format_rankings(
        rankings(summary, keys), keys) + "\n" + format_claims(claims, keys)

    def draw(folder):  # the figures show the first grid point; every point's numbers are in the tables
        shown = first_grid_point(history, axes)
        for name, _, _ in loaded:
            draw_histories(shown, name, folder)

    write_folder(output, overwrite, lambda: StudyOutput({"summary": summary, "histories": history, "claims": claims},
                                                        study_meta(loaded, runs), {"table.md": table}, draw))
    if as_json:
        from liaison_cli.report.json_summary import study_document

        echo_json(study_document("study004", output, {"summary": summary, "claims": claims}, runs=runs,
                                 grid_keys=keys))
        return
    typer.echo(table, nl=False)
    typer.echo(f"results: {output}")


@app.command("tables002")
@user_errors
def tables002(
    sweep_dir: Path = typer.Argument(..., help="a sweep over batch scenarios with --grid batch.span_days=... "
                                               "--grid measurement.interval_s=..."),
    output: Path = typer.Option(None, "--output", help="folder for the tables and histograms (default: "
                                                      "SWEEP_DIR/tables002)"),
    span_days: float = typer.Option(9.885, "--span", help="grid cell of the histograms: span (days)"),
    interval_s: float = typer.Option(1800, "--interval", help="grid cell of the histograms: interval (s)"),
    as_json: bool = json_option(),
):
    """002's Table 3 (DRMS p90) and Table 4 (clock RMS p90) layouts from a sweep, consistency, histograms; with
    the nrho_gateway_anchors_mesh* scenarios in the sweep, both readings of 002's links side by side.

    Example: liaison sweep nrho_gateway_anchors nrho_earth_station --grid batch.span_days=6.59 --grid measurement.interval_s=1800 --runs 10 --output results/sweep-002; liaison tables002 results/sweep-002 --span 6.59 --interval 1800"""
    from liaison_cli.campaign.studies.output import StudyOutput, write_files
    from liaison_cli.campaign.studies.tables002 import (NRHO_PERIOD_DAYS, batch_consistency_table, clock_rms_p90_table, drms_table,
                                                        histogram_cell, per_run_metrics)
    from liaison_cli.report.nrho002 import draw_histograms, format_batch_consistency, format_readings, format_tables

    metrics = per_run_metrics(sweep_dir)
    drms, clocks, consistency = drms_table(metrics), clock_rms_p90_table(metrics), batch_consistency_table(sweep_dir)
    readings = format_readings(drms, clocks)
    text = format_tables(drms, clocks) + ("\n" + readings if readings else "") + "\n" + format_batch_consistency(consistency)
    if not as_json:
        typer.echo(text, nl=False)
    cell = histogram_cell(metrics, span_days, interval_s)
    output_ = StudyOutput({"drms_p90": drms, "clock_p90": clocks, "per_run": metrics, "consistency": consistency},
                          {"package": "liaison", "source": str(sweep_dir), "metric": "p90 over runs with status ok"},
                          {"tables.md": text, **({"readings.md": readings} if readings else {})},
                          lambda folder: draw_histograms(cell, span_days / NRHO_PERIOD_DAYS, interval_s, folder))
    written = write_files(output or sweep_dir / "tables002", output_)
    if as_json:
        from liaison_cli.report.json_summary import study_document

        echo_json(study_document("tables002", output or sweep_dir / "tables002",
                                 {"drms_p90": drms, "clock_p90": clocks, "consistency": consistency},
                                 source=str(sweep_dir), files=[str(path) for path in written]))
        return
    for path in written:
        typer.echo(f"wrote {path}")
