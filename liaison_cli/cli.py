"""Command-line interface (thin layer): parse, call the campaign code, print, map errors to exit codes."""

import functools
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from liaison_cli import __version__, interrupts
from liaison_cli.errors import LiaisonError
from liaison_cli.report.run_text import (
    format_consistency as _format_consistency,
    format_prediction as _format_prediction,
    format_smoothed as _format_smoothed,
    format_summary as _format_summary,
    left as _left,
    rejection_line as _rejection_line,
    right as _right,
    status_line as _status_line,
)

if TYPE_CHECKING:  # pandas costs ~0.6 s to import; `version` and `--help` need not pay for it
    import pandas as pd

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="LiAISON Monte Carlo campaigns: crosslink-only orbit determination in cislunar space.",
)


def _print_version(value: bool) -> None:
    if value:
        typer.echo(__version__)
        raise typer.Exit()


@app.callback()
def _configure_process(
    _version: bool = typer.Option(False, "--version", is_eager=True, callback=_print_version,
                                  help="Print the package version and exit."),
) -> None:
    """Before every command: Ctrl-C is remembered as well as raised (liaison_cli.interrupts), and notes from
    the library (the `liaison` logger: e.g. a date past the IERS tables) go to stderr as `note: ...`."""
    interrupts.install()
    _install_note_handler()


def _install_note_handler() -> None:
    import logging

    logger = logging.getLogger("liaison")
    if not any(getattr(h, "_liaison_notes", False) for h in logger.handlers):
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("note: %(message)s"))
        handler._liaison_notes = True
        logger.addHandler(handler)
        logger.setLevel(logging.INFO)
        logger.propagate = False


EXIT_OS_ERROR = 4  # an operating-system fault while reading or writing files
EXIT_ALL_DIVERGED = 5  # the campaign ran, but no run finished healthy
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT, as a shell reports it)
INTERRUPTED_MESSAGE = ("interrupted: nothing was written and no earlier result was replaced; rerun the same "
                       "command")


def _interrupted_message() -> str:
    written = interrupts.written()
    if written:
        return (f"interrupted after the result was written: {', '.join(written)} is complete; only the printed "
                "summary was cut short")
    return INTERRUPTED_MESSAGE


def _fail(message: str, code: int) -> None:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)


def user_errors(func):
    """Turn typed errors into a one-line message and their exit code; never a traceback."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except LiaisonError as exc:
            if exc.exit_code == EXIT_INTERRUPTED:  # a sweep's own "interrupted: N of M tasks saved" line
                interrupts.ignore_from_now_on()
            _fail(str(exc), exc.exit_code)
        except KeyboardInterrupt:
            interrupts.ignore_from_now_on()  # nothing may turn exit 130 into death by SIGINT now
            _fail(_interrupted_message(), EXIT_INTERRUPTED)
        except SystemError as exc:  # Ctrl-C inside compiled code outside a worker (e.g. errors' check runs)
            if not interrupts.caused_by_interrupt(exc):
                raise
            interrupts.ignore_from_now_on()
            _fail(_interrupted_message(), EXIT_INTERRUPTED)
        except OSError as exc:  # disk full, read-only, not a directory, permission: the path and the cause
            where = exc.filename if exc.filename is not None else "file system"
            _fail(f"{where}: {exc.strerror or exc}", EXIT_OS_ERROR)

    return wrapper


@app.command()
@user_errors
def run(
    scenario: Path = typer.Argument(..., help="scenario YAML file"),
    runs: int = typer.Option(None, "--runs", min=1, help="Monte Carlo runs (default: the scenario's)"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="worker processes"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/<scenario name>)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder"),
    float64: bool = typer.Option(False, "--float64", help="store per-epoch series as float64 (default float32)"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """Run a scenario's Monte Carlo campaign (EKF, or batch least squares) and write Parquet results."""
    from liaison_cli.campaign.results import stream_campaign
    from liaison_cli.scenario.schema import load_scenario
    from liaison_cli.storage import staged_output

    _check_runs(runs)
    config, text = load_scenario(scenario)
    out_dir = output or Path("results") / config.name
    with staged_output(out_dir, overwrite) as stage:  # complete, or not there at all
        problem, summary = stream_campaign(config, stage, text, runs=runs, jobs=jobs,
                                           progress=not quiet and sys.stderr.isatty(),
                                           float_dtype="float64" if float64 else "float32")
    span = (f"batch span {config.batch.span_days:g} d + {config.batch.prediction_hours:g} h"
            if config.batch is not None else f"{config.duration_days:g} d")
    typer.echo(
        f"{config.name}: {len(problem.spacecraft)} spacecraft, {len(config.links)} link(s), "
        f"sigma {problem.sigma_m:.1f} m, {span}, seed {config.monte_carlo.seed}"
    )
    typer.echo(_format_summary(summary, problem.spacecraft))
    typer.echo(_format_consistency(summary, problem.spacecraft, config.settle_days()))
    smoothed = _format_smoothed(summary, problem.spacecraft)
    if smoothed:
        typer.echo(smoothed)
    prediction = _format_prediction(summary, problem.spacecraft)
    if prediction:
        typer.echo(prediction)
    typer.echo(_status_line(summary))
    rejections = _rejection_line(summary, config.filter)
    if rejections:
        typer.echo(rejections)
    typer.echo(f"results: {out_dir}")
    if not any(row["status"] == "ok" for row in summary):
        _fail(f"no run of {config.name} finished healthy (see the status line above); results kept in {out_dir}",
              EXIT_ALL_DIVERGED)


@app.command()
@user_errors
def table3(
    runs: int = typer.Option(10, "--runs", min=1, help="Monte Carlo runs per case"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="worker processes"),
    output: Path = typer.Option(Path("results/table3"), "--output", help="result folder"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder"),
    scenarios: Path = typer.Option(Path("scenarios"), "--scenarios", help="folder holding the paper's scenario files"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """Reproduce Turan et al. (2022) Table 3: 3 formations x 150/300 m, printed beside the paper."""
    from liaison_cli.report.table3 import run_table3
    from liaison_cli.storage import staged_output

    _check_runs(runs)
    with staged_output(output, overwrite) as stage:
        result = run_table3(scenarios, stage, runs, jobs, progress=not quiet and sys.stderr.isatty())
    typer.echo(result.markdown)
    typer.echo(f"results: {output}")


def _check_runs(runs, option: str = "--runs") -> None:
    """--runs (errors: --check-runs) obeys the same cap as the scenario's monte_carlo.runs. Every command that
    runs filters calls this first, so it is also where the first-compilation notice is armed."""
    from liaison_cli.scenario.schema import MAX_RUNS

    if runs is not None and runs > MAX_RUNS:
        raise LiaisonError(f"{option} {runs}: at most {MAX_RUNS:,} runs (the cap of monte_carlo.runs)")
    _announce_compilation()


COMPILE_NOTICE = ("liaison: compiling the numeric core for this machine (first run after installing or "
                  "upgrading: about 15 seconds; cached afterwards)")


def _announce_compilation() -> None:
    """One line on stderr when numba starts compiling liaison code (a cache miss), so a new user knows why
    the first run is slow. Loading from the cache is not compiling and stays silent."""
    from numba.core import event

    class Notice(event.Listener):
        shown = False

        def on_start(self, ev):
            function = getattr(ev.data.get("dispatcher"), "py_func", None)
            if not Notice.shown and getattr(function, "__module__", "").startswith("liaison_cli"):
                Notice.shown = True
                typer.echo(COMPILE_NOTICE, err=True)

        def on_end(self, ev):
            pass

    event.register("numba:compile", Notice())


def _plain_name(name: str) -> bool:
    """A sweep name becomes a folder under results/: it may not climb out of it or hide."""
    import re

    return bool(re.fullmatch(r"[A-Za-z0-9_+\-][A-Za-z0-9_+.\-]*", name)) and ".." not in name


PAPER_FORMATIONS = ("eml2_lunar", "eml1_lunar", "eml1_eml2")


def _curve_ratio(row: dict) -> str:
    """A curve row's error/sigma after the settle time, marked when inconsistent ('-' for a curve written before
    the consistency columns existed)."""
    ratio = row.get("position_error_to_sigma_settled")
    if ratio is None or ratio != ratio:
        return "-"
    return f"{ratio:.2f}{'' if row.get('consistent_settled', True) else ' !'}"


def _format_curve(curve: "pd.DataFrame", grid_keys) -> str:
    header = f"{'scenario':<12}{'spacecraft':<11}" + "".join(f"{k.split('.')[-1]:>12}" for k in grid_keys)
    lines = [header + f"{'runs ok':>9}{'pos RMS m (p10-p90)':>26}{'vel RMS mm/s':>14}{'err/σ >settle':>15}"]
    for row in curve.to_dict("records"):
        cells = "".join(_right(str(row[k]), 12) for k in grid_keys)
        band = f"{row['rms_position_m_mean']:.1f} ({row['rms_position_m_p10']:.0f}-{row['rms_position_m_p90']:.0f})"
        lines.append(
            _left(row["scenario"], 12) + _left(row["spacecraft"], 11) + cells
            + _right(f"{row['runs_ok']}/{row['runs']}", 9) + _right(band, 26)
            + _right(f"{1e3 * row['rms_velocity_m_s_mean']:.3f}", 14)
            + _right(_curve_ratio(row), 15)
        )
    if "consistent_settled" in curve and not curve.consistent_settled.all():
        from liaison_cli.analysis.metrics import CONSISTENCY_RATIO_LIMIT

        lines.append(f"! inconsistent after the settle time: error RMS above {CONSISTENCY_RATIO_LIMIT:g}x the "
                     "filter's sigma RMS (curve.parquet: *_error_to_sigma_settled)")
    return "\n".join(lines)


@app.command()
@user_errors
def sweep(
    scenario_args: list[Path] = typer.Argument(None, metavar="[SCENARIO]...",
                                               help="scenario YAML files (default: the paper's three formations)"),
    scenario_opts: list[Path] = typer.Option(None, "--scenario", help="scenario YAML file (may repeat)"),
    sigma: str = typer.Option(None, "--sigma", help="ranging sigma grid in m: start:stop[:step] (step 50) or a,b,c"),
    grid: list[str] = typer.Option(None, "--grid", help="KEY=V1,V2,... over any scenario field by dotted path "
                                                        "(may repeat; full factorial)"),
    runs: int = typer.Option(10, "--runs", min=1, help="Monte Carlo runs per grid point"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="worker processes (joblib) or LocalCluster workers (dask)"),
    backend: str = typer.Option("joblib", "--backend", help="joblib (local processes) or dask (dask.distributed)"),
    scheduler: str = typer.Option(None, "--scheduler", help="dask scheduler address, e.g. tcp://host:8786"),
    scheduler_timeout: float = typer.Option(20.0, "--scheduler-timeout", min=0.1,
                                            help="seconds to wait for the dask scheduler"),
    name: str = typer.Option(None, "--name", help="sweep name (default: fig15 for the paper's formations)"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/sweep-<name>)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="discard an existing sweep in the folder"),
    scenarios_dir: Path = typer.Option(Path("scenarios"), "--scenarios",
                                       help="folder of the paper's scenario files (when none is named)"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """Sweep scenarios over a grid (ranging sigma, or any field); resumable, backend-independent results."""
    from liaison_cli.campaign.grid import check_grid_size, parse_grid, parse_range
    from liaison_cli.storage import resumable_output
    from liaison_cli.scenario.schema import load_scenario
    from liaison_cli.campaign.backends import check_backend, probe_scheduler
    from liaison_cli.campaign.sweep import SIGMA_KEY, plan_sweep, run_sweep, sweep_lock

    _check_runs(runs)
    check_backend(backend, scheduler)
    if scheduler:  # before the lock and any work: a bad scheduler is one line within --scheduler-timeout
        probe_scheduler(scheduler, scheduler_timeout)
    paths = list(scenario_args or []) + list(scenario_opts or [])
    default_formations = not paths
    if default_formations:
        paths = [scenarios_dir / f"{formation}.yaml" for formation in PAPER_FORMATIONS]
    axes = [parse_grid(text) for text in grid or []]
    if sigma is not None:
        axes.insert(0, (SIGMA_KEY, parse_range(sigma, "--sigma")))
    if not axes:
        raise LiaisonError("sweep: nothing to sweep; give --sigma and/or --grid KEY=V1,V2")
    check_grid_size(axes, len(paths), runs)
    bases = [(*load_scenario(path), str(path)) for path in paths]
    if name is None:
        name = "fig15" if default_formations else "+".join(b[0].name for b in bases)
    elif not _plain_name(name):
        raise LiaisonError(f"--name {name!r}: a plain name is needed (letters, digits, '_', '-', '+', '.'; no path "
                           "separators, no '..', not starting with '.'); use --output to choose a folder")
    plan = plan_sweep(bases, axes, runs, name)
    out_dir = output or Path("results") / f"sweep-{name}"
    with sweep_lock(out_dir), resumable_output(out_dir, overwrite, plan.key()) as work_dir:
        result = run_sweep(plan, work_dir, backend=backend, jobs=jobs, scheduler=scheduler,
                           progress=not quiet and sys.stderr.isatty(), connect_timeout_s=scheduler_timeout)
    typer.echo(_format_curve(result.curve_table, [k for k, _ in axes]))
    excluded = int(result.curve_table.runs_excluded.sum())
    total = len(plan.tasks)
    typer.echo(f"{len(plan.points)} grid points x {runs} runs = {total} tasks: {result.computed} computed, "
               f"{result.reused} reused from the manifest"
               + (f"; {excluded} spacecraft-runs diverged or failed and are excluded from the curves"
                  if excluded else ""))
    typer.echo(f"results: {out_dir}")
    curve = result.curve_table
    empty = curve[curve.runs_ok == 0].drop_duplicates("point")
    if len(empty) == curve.point.nunique():
        _fail(f"no run of sweep {name} finished healthy (see the manifest's reasons); results kept in {out_dir}",
              EXIT_ALL_DIVERGED)
    if len(empty):
        typer.echo(f"warning: no healthy run at {len(empty)} grid point(s) ({', '.join(map(str, empty.point))}); "
                   "their curve values are empty", err=True)


@app.command("errors")
@user_errors
def errors(
    scenario_path: Path = typer.Argument(..., metavar="SCENARIO", help="scenario YAML (estimator: ekf)"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/<name>-errors)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an earlier error budget there"),
    sources: str = typer.Option(None, "--sources", help="comma list of sources to check by Monte Carlo "
                                "(initial, noise, process, bias, measurement_model, dynamics_model)"),
    check_runs: int = typer.Option(0, "--check-runs", min=0, help="Monte Carlo runs for the check (0: none)"),
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

    _check_runs(check_runs, "--check-runs")
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
    typer.echo(f"{scenario.name}: share of the mean-square error by source (LinCov along the truth, "
               f"{scenario.duration_days:g} d)")
    typer.echo(table, nl=False)
    settle_s = scenario.settle_days() * SECONDS_PER_DAY
    checks = monte_carlo_check(problem, budget, check_runs, chosen, settle_s) if check_runs else []
    if checks:
        typer.echo(f"Monte Carlo ({check_runs} runs of the EKF) over LinCov, mean-square error after t0:")
        for row in checks:
            typer.echo(f"  {row['sources']:<32}{row['spacecraft']:<10}{row['quantity']:<10}"
                       f"{row['monte_carlo_over_lincov']:8.3f}")
    consistency_rows = consistency(budget, settle_s)
    nees_share = checks[0]["nees_in_band_share_settled"] if checks and chosen == SOURCES else None
    for row in consistency_rows:
        row["nees_in_band_share_settled"] = float("nan") if nees_share is None else nees_share
    consistency_text = format_consistency(consistency_rows, scenario.settle_days(), nees_share, check_runs)
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
    typer.echo(f"results: {out_dir}")


def _load_study(paths: list[Path]) -> list:
    """[(name = file stem, scenario, text)] of a study's scenario files. The stem labels the study's rows,
    metadata and figures, so two files with one stem would be merged into one label: refused."""
    from liaison_cli.scenario.schema import load_scenario

    _refuse_repeated_labels([(Path(path), Path(path).stem) for path in paths], "file stem")
    return [(Path(path).stem, *load_scenario(path)) for path in paths]


def _refuse_repeated_labels(labelled: list, what: str) -> None:
    """labelled: [(path, label)]; a label given twice is one line naming the second file."""
    first: dict = {}
    for path, label in labelled:
        if label in first:
            raise LiaisonError(f"{path}: {what} {label!r} is also that of {first[label]}; allowed: scenarios with "
                               f"distinct {what}s (each labels its own rows, metadata and figures)")
        first[label] = path


def _write_study(output: Path, overwrite: bool, loaded, runs: int, summary, history, table: str, draw) -> None:
    """A study's table, Parquet (scenario texts, seeds and version in the metadata) and figures, swapped in
    whole; `draw(history, stage)` draws the figures into the staging folder."""
    from liaison_cli.storage import staged_output, write_parquet_atomic, write_text_atomic

    typer.echo(table, nl=False)
    meta = {"package": "liaison", "version": __version__, "runs": runs,
            "scenarios_yaml": {name: text for name, _, text in loaded},
            "seeds": {name: scenario.monte_carlo.seed for name, scenario, _ in loaded}}
    with staged_output(output, overwrite) as stage:
        write_parquet_atomic(summary, stage / "summary.parquet", meta)
        write_parquet_atomic(history, stage / "histories.parquet", meta)
        write_text_atomic(table, stage / "table.md")
        draw(history, stage)
    typer.echo(f"results: {output}")


STUDY003_MISSIONS = ("scenarios/003/cassini.yaml", "scenarios/003/mer_a.yaml", "scenarios/003/msl.yaml")


@app.command("study003")
@user_errors
def study003(
    scenarios: list[Path] = typer.Argument(None, metavar="[SCENARIO]...", help="missions' full-set scenarios "
                                           "(default: scenarios/003/cassini, mer_a, msl)"),
    runs: int = typer.Option(50, "--runs", min=1, help="Monte Carlo runs per mission and case"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="worker processes"),
    output: Path = typer.Option(Path("results/study003"), "--output", help="result folder"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an earlier study there"),
    grid: list[str] = typer.Option(None, "--grid", help="KEY=V1,V2: repeat the study over filter settings "
                                   "(e.g. filter.underweighting=0,0.2); repeatable"),
    dsn_noise: str = typer.Option(None, "--dsn-noise", help="set every ground link's noise to one of 003's "
                                  "readings: table2 (10 m, 0.5 mm/s) or text (1 m, 0.1 mm/s); default: the files'"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """003's study: each departure mission x (DSN + LiAISON, DSN only, LiAISON only); 3D RMS table, figures."""
    from liaison_cli.campaign.grid import check_grid_size, parse_grid
    from liaison_cli.campaign.study003 import DSN_NOISE_READINGS, run_study, tuning
    from liaison_cli.report.study003 import draw_comparison, draw_mission, format_table

    _check_runs(runs)
    if dsn_noise is not None and dsn_noise not in DSN_NOISE_READINGS:
        raise LiaisonError(f"--dsn-noise {dsn_noise!r}: allowed: {', '.join(DSN_NOISE_READINGS)}")
    axes = [parse_grid(text) for text in grid or []]
    check_grid_size(axes, 1, runs)
    loaded = _load_study(scenarios or [Path(p) for p in STUDY003_MISSIONS])
    summary, history, _ = run_study([(name, scenario) for name, scenario, _ in loaded], runs, jobs, not quiet,
                                    grid=axes, dsn_noise=dsn_noise)
    first = loaded[0][1]
    noise = (f"003 {dsn_noise} {DSN_NOISE_READINGS[dsn_noise]}" if dsn_noise else "as in the scenario files")
    typer.echo(f"003 study, {runs} runs per case, DSN noise: {noise}; "
               f"3D RMS after t0 (σ: the filter's; 003: its stated full-set values). Filter ({first.name}): "
               f"{tuning(first)}" + (f"; grid over {', '.join(k for k, _ in axes)}" if axes else ""))

    def draw(history_, stage):
        if axes:  # the figures show the first grid point; every point's numbers are in the tables
            first_point = history_
            for key, values in axes:
                first_point = first_point[first_point[key] == values[0]]
            history_ = first_point
        for name, _, _ in loaded:
            draw_mission(history_, name, stage)
        draw_comparison(history_, stage)

    table = format_table(summary, [k for k, _ in axes], first.settle_days())
    _write_study(output, overwrite, loaded, runs, summary, history, table, draw)


STUDY004_TRANSMITTERS = ("scenarios/004/eml2_halo.yaml", "scenarios/004/dro.yaml",
                         "scenarios/004/low_energy_transfer.yaml")


@app.command("study004")
@user_errors
def study004(
    scenarios: list[Path] = typer.Argument(None, metavar="[SCENARIO]...", help="transmitter scenarios, one link "
                                           "per receiver pair (default: scenarios/004/eml2_halo, dro, "
                                           "low_energy_transfer)"),
    runs: int = typer.Option(10, "--runs", min=1, help="Monte Carlo runs per transmitter and pair"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="worker processes"),
    output: Path = typer.Option(Path("results/study004"), "--output", help="result folder"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an earlier study there"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """004's study: each transmitter x receiver pair (TDoA + FDoA); 3σ histories, convergence, DOP, table."""
    from liaison_cli.campaign.study004 import run_study
    from liaison_cli.report.study004 import draw_histories, format_table

    _check_runs(runs)
    loaded = _load_study(scenarios or [Path(p) for p in STUDY004_TRANSMITTERS])
    summary, history = run_study([(name, scenario) for name, scenario, _ in loaded], runs, jobs, not quiet)
    typer.echo(f"004 study, {runs} runs per case: steady state = median 3σ over the last quarter; converged = "
               "3σ position below twice it from then on")

    def draw(history_, stage):
        for name, _, _ in loaded:
            draw_histories(history_, name, stage)

    _write_study(output, overwrite, loaded, runs, summary, history, format_table(summary), draw)


@app.command("tables002")
@user_errors
def tables002(
    sweep_dir: Path = typer.Argument(..., help="a sweep over batch scenarios with --grid batch.span_days=... "
                                               "--grid measurement.interval_s=..."),
    output: Path = typer.Option(None, "--output", help="folder for the tables and histograms (default: "
                                                      "SWEEP_DIR/tables002)"),
    span_days: float = typer.Option(9.885, "--span", help="grid cell of the histograms: span (days)"),
    interval_s: float = typer.Option(1800, "--interval", help="grid cell of the histograms: interval (s)"),
):
    """002's Table 3 (DRMS p90) and Table 4 (clock RMS p90) layouts from a sweep, consistency, histograms."""
    from liaison_cli.report.nrho002 import (clock_table, consistency_table, draw_histograms, drms_table,
                                            format_consistency, format_tables, per_run_metrics)
    from liaison_cli.storage import write_parquet_atomic, write_text_atomic

    metrics = per_run_metrics(sweep_dir)
    drms, clocks, consistency = drms_table(metrics), clock_table(metrics), consistency_table(sweep_dir)
    text = format_tables(drms, clocks) + "\n" + format_consistency(consistency)
    typer.echo(text, nl=False)
    out_dir = output or sweep_dir / "tables002"
    out_dir.mkdir(parents=True, exist_ok=True)
    meta = {"package": "liaison", "source": str(sweep_dir), "metric": "p90 over runs with status ok"}
    paths = [out_dir / "drms_p90.parquet", out_dir / "clock_p90.parquet", out_dir / "per_run.parquet",
             out_dir / "consistency.parquet", out_dir / "tables.md"]
    write_parquet_atomic(drms, paths[0], meta)
    write_parquet_atomic(clocks, paths[1], meta)
    write_parquet_atomic(metrics, paths[2], meta)
    write_parquet_atomic(consistency, paths[3], meta)
    write_text_atomic(text, paths[4])
    paths += draw_histograms(metrics, span_days, interval_s, out_dir)
    for path in paths:
        typer.echo(f"wrote {path}")


@app.command("tune")
@user_errors
def tune(
    scenarios: list[Path] = typer.Argument(..., metavar="SCENARIO...", help="scenario YAML files (labelled by "
                                           "file stem)"),
    ladder: str = typer.Option(None, "--ladder", help="process-noise rungs in m/s^2, a comma list "
                               "[default: 1e-10,1e-9,1e-8,1e-7,1e-6,1e-5]"),
    runs: int = typer.Option(20, "--runs", min=1, help="Monte Carlo runs per rung"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="worker processes"),
    work: Path = typer.Option(Path("results/tune"), "--work", help="folder of the rungs' sweeps (resumed, reused)"),
    table: Path = typer.Option(Path("results/tune/consistency.md"), "--table",
                               help="the Markdown table to write; the Parquet goes beside it (.parquet)"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bars"),
):
    """Consistency of each scenario's shipped process noise, and the SNC a stated rule chooses on a ladder."""
    from liaison_cli.campaign.tuning import TuningCase, parse_ladder, rule_text, tune as run_tuning
    from liaison_cli.report.tuning import format_ladder, format_table, paper_tuned_notes
    from liaison_cli.storage import write_parquet_atomic, write_text_atomic

    _check_runs(runs)
    rungs = parse_ladder(ladder)
    if table.suffix != ".md" or table.is_dir():
        raise LiaisonError(f"--table {table}: allowed: a Markdown file path ending in .md (the Parquet goes beside it)")
    loaded = _load_study(scenarios)
    cases = [TuningCase(name, scenario, text, str(path)) for path, (name, scenario, text) in zip(scenarios, loaded)]
    frame = run_tuning(cases, rungs, runs, work, jobs, progress=not quiet and sys.stderr.isatty(),
                       on_case=None if quiet else lambda label: typer.echo(f"tune: {label}", err=True))
    typer.echo(format_ladder(frame))
    settle = sorted({(case.scenario.settle_days(), case.label) for case in cases})
    other = [f"{label} {days:g} d" for days, label in settle if days != 1.0]
    settle_note = "filter.settle_days; 1 d" + (f" except {', '.join(other)}" if other else "")
    command = " ".join(["liaison tune", *map(str, scenarios), f"--runs {runs}"]
                       + ([f"--ladder {ladder}"] if ladder else []) + [f"--table {table}"])
    markdown = format_table(frame, rule_text(rungs, runs), command, settle_note, paper_tuned_notes())
    meta = {"package": "liaison", "version": __version__, "command": command, "rule": rule_text(rungs, runs),
            "scenarios_yaml": {case.label: case.text for case in cases},
            "seeds": {case.label: case.scenario.monte_carlo.seed for case in cases}}
    table.parent.mkdir(parents=True, exist_ok=True)
    write_parquet_atomic(frame, table.with_suffix(".parquet"), meta)
    write_text_atomic(markdown, table)
    typer.echo(f"wrote {table} and {table.with_suffix('.parquet')}")


plot_app = typer.Typer(no_args_is_help=True, help="Figures from result folders (PNG + SVG).")
app.add_typer(plot_app, name="plot")


@plot_app.command("fig15")
@user_errors
def plot_fig15(
    sweep_dir: Path = typer.Argument(..., help="folder written by 'liaison sweep --sigma ...'"),
    output: Path = typer.Option(None, "--output", help="file stem for .png/.svg (default: SWEEP_DIR/fig15)"),
    title: str = typer.Option(None, "--title", help="figure title"),
):
    """Error vs ranging sigma (Fig. 15), one line per formation and spacecraft, Table 3 overlaid."""
    from liaison_cli.report.fig15 import draw_fig15, load_curve, paper_points_vs_curve

    curve = load_curve(sweep_dir)
    paths = draw_fig15(curve, output or sweep_dir / "fig15", title)
    check = paper_points_vs_curve(curve)
    if len(check):
        typer.echo("Turan et al. 2022 Table 3 against our curve (mean of run RMS, interpolated in sigma):")
        for row in check.itertuples():
            scale, unit = (1.0, "m") if row.metric == "rms_position_m" else (1e3, "mm/s")
            typer.echo(f"  {row.scenario:<11}{row.spacecraft:<7}{row.sigma_m:>5.0f} m  {row.metric[4:12]:<9}"
                       f"ours {scale * row.ours:9.2f} {unit:<5} paper {scale * row.paper:9.2f} {unit:<5}"
                       f"ratio {row.ratio:5.2f}")
    for path in paths:
        typer.echo(f"wrote {path}")


def _print_dual_one_way(spec) -> None:
    receiver = spec.receiver()
    sig = receiver.sigmas()
    typer.echo(f"dual one-way receiver (002 Eq. 8-12): carrier {spec.carrier_frequency_hz / 1e9:g} GHz, "
               f"C/N0 {spec.c_n0_db_hz:g} dB-Hz, code {spec.chip_rate_hz / 1e6:g} Mcps in {spec.front_end_bandwidth_hz / 1e6:g} MHz, "
               f"early-late spacing {receiver.spacing_chips:.3f} chips")
    typer.echo(f"  {'TOA Cramér-Rao bound (Eq. 8), range':<44}{sig['toa_crb_range_m']:10.3f} m"
               f"   (Gabor bandwidth {sig['gabor_bandwidth_hz'] / 1e3:.0f} kHz, T {spec.code_integration_s:g} s)")
    typer.echo(f"  {'DLL code tracking (Eq. 11), range':<44}{sig['dll_range_m']:10.3f} m"
               f"   ({sig['dll_regime']}, B_n {spec.code_loop_bandwidth_hz:g} Hz)")
    typer.echo(f"  {'FOA Cramér-Rao bound (Eq. 10), range-rate':<44}{1e3 * sig['foa_crb_range_rate_m_s']:10.4f} mm/s"
               f" (T {spec.carrier_integration_s:g} s)")
    typer.echo(f"  {'PLL Doppler (Eq. 12), range-rate':<44}{1e3 * sig['pll_range_rate_m_s']:10.4f} mm/s"
               f" (B_d {spec.doppler_bandwidth_hz:g} Hz)")


@app.command()
@user_errors
def budget(
    link_file: Path = typer.Argument(..., help="link YAML: link_budget {uplink, downlink} + ranging parameters"),
    sweep_dir: Path = typer.Option(None, "--sweep", help="a 'liaison sweep --sigma' folder to read errors from"),
):
    """Ranging sigma of each method from a link budget; with --sweep, the expected OD errors (Fig. 15 read-off)."""
    from liaison_cli.scenario.schema import load_link_file
    from liaison_cli.report.budget import METHOD_LABELS, expected_errors

    link = load_link_file(link_file)
    if link.dual_one_way is not None:
        _print_dual_one_way(link.dual_one_way)
    if link.link_budget is None:
        return
    for leg_name in ("uplink", "downlink"):
        leg = getattr(link.link_budget, leg_name).leg()
        typer.echo(f"{leg_name:<9} {leg.distance_km:,.0f} km, {leg.data_rate_bps:,.0f} bps: free-space loss "
                   f"{leg.free_space_loss_db:.2f} dB, C/N0 {leg.c_over_n0_dbhz:.2f} dB-Hz, "
                   f"Es/N0 {leg.es_over_n0_db:.2f} dB (margin {leg.margin_db:g} dB held back)")
    sigmas = link.sigma_by_method()
    typer.echo(f"ranging sigma (1σ, correlator integration {link.correlator_integration_s:g} s):")
    for method, sigma in sigmas.items():
        shown = f"{sigma:10.1f} m" if sigma is not None else (
            "   not computed: needs ranging_clock_hz, loop_bandwidth_hz, ranging_power_fraction_db")
        typer.echo(f"  {METHOD_LABELS[method]:<22}{shown}")
    if link.carrier is not None:
        carrier = link.carrier.sigmas(link.link_budget)
        count_s = link.carrier.doppler_count_s
        typer.echo(f"carrier ({link.carrier.power_fraction_db:g} dB of each leg, {link.carrier.loop_bandwidth_hz:g} Hz "
                   f"loops): loop SNR up {10 * math.log10(carrier['uplink_loop_snr']):.1f} dB, down "
                   f"{10 * math.log10(carrier['downlink_loop_snr']):.1f} dB")
        doppler = f"two-way Doppler (Eq. 5), {count_s:g} s count"
        typer.echo(f"  {doppler:<40}{1e3 * carrier['range_rate_sigma_m_s']:10.4f} mm/s")
        typer.echo(f"  {'LOS interferometer path (Eq. 9)':<40}{1e3 * carrier['los_path_sigma_m']:10.3f} mm")
        typer.echo("range / range-rate sigma ratio (Eq. 65):")
        for method, sigma in sigmas.items():
            if sigma is not None:
                typer.echo(f"  {METHOD_LABELS[method]:<22}{sigma / carrier['range_rate_sigma_m_s']:10.0f} s")
    if sweep_dir is None:
        return
    from liaison_cli.report.fig15 import load_curve

    table = expected_errors(load_curve(sweep_dir), sigmas)
    typer.echo(f"expected OD error from {sweep_dir} (mean of run RMS [90th percentile], interpolated in sigma):")
    typer.echo(f"  {'method':<14}{'sigma m':>9}  {'scenario':<12}{'spacecraft':<11}{'position m':>20}"
               f"{'velocity mm/s':>22}")
    for row in table.itertuples():
        if row.inside_swept_range:
            pos = f"{row.rms_position_m_mean:.0f} [{row.rms_position_m_p90:.0f}]"
            vel = f"{1e3 * row.rms_velocity_m_s_mean:.2f} [{1e3 * row.rms_velocity_m_s_p90:.2f}]"
        else:
            pos, vel = f"outside swept {row.swept_min_m:g}-{row.swept_max_m:g} m", ""
        typer.echo(f"  {row.method:<14}{row.sigma_m:>9.1f}  {row.scenario:<12}{row.spacecraft:<11}{pos:>20}{vel:>22}")


orbits_app = typer.Typer(no_args_is_help=True, help="Periodic-orbit families of the Earth-Moon CRTBP.")
app.add_typer(orbits_app, name="orbits")


def _family_table(name: str, count: int, regenerate: bool = False):
    from liaison_cli.orbits.family_store import load_or_generate
    from liaison_cli.orbits.families import FamilyError

    try:
        return load_or_generate(name, count, regenerate)
    except FamilyError as exc:
        raise LiaisonError(str(exc)) from None


def _format_family(frame) -> str:
    from liaison_cli.dynamics.constants import LU_KM

    lines = [f"{'#':>3}{'x0 LU':>12}{'z0 LU':>11}{'vy0 LU/TU':>12}{'period d':>10}{'Jacobi':>9}"
             f"{'stab. index':>13}{'Az km':>9}{'perilune km':>13}{'closure LU':>12}"]
    for row in frame.itertuples():
        lines.append(f"{row.member:>3}{row.x0:>12.7f}{row.z0:>11.7f}{row.vy0:>12.7f}{row.period_days:>10.4f}"
                     f"{row.jacobi:>9.5f}{row.stability_index:>13.2f}{row.z_amplitude_lu * LU_KM:>9.0f}"
                     f"{row.perilune_km:>13.0f}{row.closure_lu:>12.1e}")
    return "\n".join(lines)


@orbits_app.command("generate")
@user_errors
def orbits_generate(
    family: str = typer.Argument(..., help="family name (see 'liaison orbits list')"),
    count: int = typer.Option(30, "--count", min=2, max=500, help="members to store"),
    regenerate: bool = typer.Option(False, "--regenerate", help="ignore the cache"),
):
    """Correct and continue a family; store its table (Parquet) in the user cache."""
    import time

    from liaison_cli.orbits.family_store import family_path

    start = time.perf_counter()
    frame, cached = _family_table(family, count, regenerate)
    typer.echo(_format_family(frame))
    how = "read from the cache" if cached else "generated"
    typer.echo(f"{family}: {len(frame)} members, periods {frame.period_days.min():.3f}-"
               f"{frame.period_days.max():.3f} d, {how} in {time.perf_counter() - start:.1f} s: "
               f"{family_path(family, count)}")


@orbits_app.command("list")
def orbits_list():
    """The known families and the tables already in the cache."""
    from liaison_cli.orbits.family_store import cached_families
    from liaison_cli.orbits.families import FAMILIES

    for name in sorted(FAMILIES):
        typer.echo(f"{name:<16}{FAMILIES[name].description}")
    tables = cached_families()
    typer.echo(f"cached tables ({len(tables)}):" if tables else "no cached tables yet")
    for path in tables:
        typer.echo(f"  {path}")


@orbits_app.command("show")
@user_errors
def orbits_show(
    family: str = typer.Argument(..., help="family name"),
    count: int = typer.Option(30, "--count", min=2, max=500, help="members (generated if not cached)"),
):
    """Print a family table (generating it first if needed)."""
    frame, _ = _family_table(family, count)
    typer.echo(_format_family(frame))


@orbits_app.command("plot")
@user_errors
def orbits_plot(
    family: str = typer.Argument(..., help="family name"),
    count: int = typer.Option(30, "--count", min=2, max=500, help="members (generated if not cached)"),
    output: Path = typer.Option(None, "--output", help="PNG path (default: results/orbits/<family>.png)"),
):
    """Draw a family in the x-y, x-z and y-z planes, coloured by period (PNG)."""
    from liaison_cli.orbits.family_store import from_table
    from liaison_cli.report.orbit_plots import draw_family

    frame, _ = _family_table(family, count)
    path = draw_family(family, from_table(frame), output or Path("results") / "orbits" / f"{family}.png")
    typer.echo(f"wrote {path}")


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
):
    """Information matrix, SVD, condition number, unobservability index and effectiveness (no a-priori)."""
    from liaison_cli.storage import staged_output
    from liaison_cli.scenario.schema import load_scenario
    from liaison_cli.report.observability_report import check_supported, observability_report

    config, text = load_scenario(scenario)
    check_supported(config, str(scenario))
    if range_rate_sigma_m_s is None:
        range_rate_sigma_m_s = config.noise.resolved_range_rate_sigma_m_s() or 1e-3
    out_dir = output or Path("results") / f"observability-{config.name}"
    with staged_output(out_dir, overwrite) as stage:
        summary = observability_report(config, text, stage, range_rate_sigma_m_s, taylor=not no_taylor)
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
):
    """Formation-geometry study: condition number of every L1 x L2 halo pair and L2 halo x lunar orbiter."""
    from liaison_cli.storage import staged_output
    from liaison_cli.report.geometry import run_study

    out_dir = output
    with staged_output(out_dir, overwrite) as stage:
        tables = run_study(stage, count, interval_s)
    for key, table in tables.items():
        for observable in ("range", "range_rate"):
            col = table[f"{observable}_condition_number"]
            best, worst = table.loc[col.idxmin()], table.loc[col.idxmax()]
            typer.echo(f"{key:<14}{observable:<11} cond {col.min():.2e} ({best['first']} / {best['second']}) to "
                       f"{col.max():.2e} ({worst['first']} / {worst['second']})")
    typer.echo(f"results: {out_dir}")


@app.command()
@user_errors
def compare(
    scenarios: list[Path] = typer.Argument(..., help="scenario YAML files to run side by side"),
    runs: int = typer.Option(None, "--runs", min=1, help="Monte Carlo runs per scenario (default: each scenario's)"),
    jobs: int = typer.Option(2, "--jobs", min=1, help="worker processes"),
    output: Path = typer.Option(Path("results/compare"), "--output", help="result folder"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace an existing result folder"),
    quiet: bool = typer.Option(False, "--quiet", help="no progress bar"),
):
    """Run several scenarios; tabulate RMS errors averaged over each scenario's spacecraft (001 Tables 6-7)."""
    from liaison_cli.campaign.results import summarise_campaign
    from liaison_cli.report.compare import compare_rows, write_compare
    from liaison_cli.scenario.schema import load_scenario
    from liaison_cli.storage import staged_output

    _check_runs(runs)
    loaded = [(path, *load_scenario(path)) for path in scenarios]
    _refuse_repeated_labels([(path, config.name) for path, config, _ in loaded], "name")
    rows, summaries, texts = [], [], {}
    with staged_output(output, overwrite) as stage:
        for path, config, text in loaded:
            _, summary = summarise_campaign(config, runs=runs, jobs=jobs,
                                            progress=not quiet and sys.stderr.isatty(), description=config.name)
            rows.append(compare_rows(config, summary))
            summaries.append(summary.assign(scenario=config.name))
            texts[config.name] = text
        table, markdown = write_compare(rows, summaries, texts, stage)
    typer.echo(markdown)
    typer.echo(f"results: {output}")


@app.command()
def version():
    """Print the package version."""
    typer.echo(__version__)


@app.command()
@user_errors
def schema(
    output: Path = typer.Option(None, "--output", help="write it to this file (atomically) instead of printing"),
):
    """Print the scenario JSON Schema (every key's description, unit and allowed values) for editors."""
    from liaison_cli.scenario.json_schema import scenario_json_schema_text

    text = scenario_json_schema_text()
    if output is None:
        typer.echo(text, nl=False)
        return
    from liaison_cli.storage import write_text_atomic

    if output.is_dir():
        raise LiaisonError(f"{output}: a directory; allowed: a file path for the schema")
    write_text_atomic(text, output)
    typer.echo(f"wrote {output}")


@app.command()
@user_errors
def validate(files: list[Path] = typer.Argument(..., metavar="FILE...", help="scenario or link YAML files")):
    """Check scenarios (and link files) as `run` (and `budget`) would, without propagating: one line each."""
    from liaison_cli.scenario.schema import check_file

    bad = 0
    for path in files:
        try:
            check_file(path)
            typer.echo(f"ok: {path}")
        except LiaisonError as exc:  # one line per bad file, and on to the next
            typer.echo(f"error: {exc}", err=True)
            bad += 1
    if bad:
        raise typer.Exit(2)


def main():  # pragma: no cover - console entry point
    app()
