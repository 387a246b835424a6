"""`liaison sweep`: scenarios over a grid of settings, resumable, and its curve table."""

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from liaison_cli.cli.common import (EXIT_ALL_DIVERGED, BackendOption, JobsOption, QuietOption, SchedulerOption,
                                    SchedulerTimeoutOption, check_runs, echo_json, fail, fan_out, json_option,
                                    plain_name, user_errors)
from liaison_cli.cli.root import app
from liaison_cli.errors import LiaisonError
from liaison_cli.report.run_text import left as _left, right as _right
from liaison_cli.scenario.shipped import scenario_folder

if TYPE_CHECKING:  # pandas costs ~0.6 s to import; `version` and `--help` need not pay for it
    import pandas as pd

PAPER_FORMATIONS = ("eml2_lunar", "eml1_lunar", "eml1_eml2")


def _curve_ratio(row: dict) -> str:
    """A curve row's error/sigma after the settle time, marked when inconsistent ('-' for a curve written before
    the consistency columns existed)."""
    ratio = row.get("position_error_to_sigma_settled")
    if ratio is None or ratio != ratio:
        return "-"
    return f"{ratio:.2f}{'' if row.get('consistent_settled', True) else ' !'}"


def _column_labels(grid_keys) -> list[str]:
    """Each grid key's column label: its last component, or more of its path where two keys would share one
    (filter.process_noise_accel_m_s2 beside spacecraft.1.process_noise_accel_m_s2)."""
    labels = {}
    for key in grid_keys:
        parts = key.split(".")
        depth = 1
        while depth < len(parts) and sum(k.split(".")[-depth:] == parts[-depth:] for k in grid_keys) > 1:
            depth += 1
        if depth < len(parts) and parts[-depth].isdigit():  # 'spacecraft.1.x', not '1.x'
            depth += 1
        labels[key] = ".".join(parts[-depth:])
    return [labels[key] for key in grid_keys]


def _format_curve(curve: "pd.DataFrame", grid_keys) -> str:
    labels = _column_labels(grid_keys)
    widths = [max(12, len(label) + 2) for label in labels]
    header = f"{'scenario':<12}{'spacecraft':<11}" + "".join(_right(label, w) for label, w in zip(labels, widths))
    lines = [header + f"{'runs ok':>9}{'pos RMS m (p10-p90)':>26}{'vel RMS mm/s':>14}{'err/σ >settle':>15}"]
    for row in curve.to_dict("records"):
        cells = "".join(_right(str(row[k]), w) for k, w in zip(grid_keys, widths))
        band = f"{row['rms_position_m_mean']:.1f} ({row['rms_position_m_p10']:.0f}-{row['rms_position_m_p90']:.0f})"
        lines.append(
            _left(row["scenario"], 12) + _left(row["spacecraft"], 11) + cells
            + _right(f"{row['runs_ok']}/{row['runs']}", 9) + _right(band, 26)
            + _right(f"{1e3 * row['rms_velocity_m_s_mean']:.3f}", 14)
            + _right(_curve_ratio(row), 15)
        )
    if "consistent_settled" in curve and not curve.consistent_settled.all():
        lines.append("! inconsistent after the settle time: the point fails the consistency verdict (the NEES test "
                     "or the error/σ ratio's interval; curve.parquet: consistency_failed says which)")
    return "\n".join(lines)


@app.command()
@user_errors
def sweep(
    scenario_args: list[Path] = typer.Argument(None, metavar="[SCENARIO]...",
                                               help="scenario YAML files (default: the paper's three "
                                                    "formations, shipped: see --scenarios)"),
    scenario_opts: list[Path] = typer.Option(None, "--scenario", help="scenario YAML file (may repeat)"),
    sigma: str = typer.Option(None, "--sigma", help="ranging sigma grid in m: start:stop[:step] (step 50) or a,b,c"),
    grid: list[str] = typer.Option(None, "--grid", help="KEY=V1,V2,... over any scenario field by dotted path "
                                                        "(may repeat; full factorial)"),
    runs: int = typer.Option(10, "--runs", min=1, help="Monte Carlo runs per grid point"),
    jobs: JobsOption = 2,
    backend: BackendOption = "joblib",
    scheduler: SchedulerOption = None,
    scheduler_timeout: SchedulerTimeoutOption = 20.0,
    name: str = typer.Option(None, "--name", help="sweep name (default: fig15 for the paper's formations)"),
    output: Path = typer.Option(None, "--output", help="result folder (default: results/sweep-<name>)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="discard an existing sweep in the folder"),
    scenarios_dir: Path = typer.Option(None, "--scenarios",
                                       help="folder of the paper's scenario files (when none is named; "
                                            "default: the shipped scenarios/, read from the installed package "
                                            "whatever the working folder)"),
    quiet: QuietOption = False,
    as_json: bool = json_option(),
):
    """Sweep scenarios over a grid (ranging sigma, or any field); resumable, backend-independent results.

    Examples: liaison sweep --sigma 50:700 --runs 10 (Fig. 15);
    liaison sweep scenarios/eml2_lunar.yaml --grid measurement.interval_s=60,187.5,600 --runs 20"""
    from liaison_cli.campaign.sweep.grid import check_grid_size, parse_grid, parse_range
    from liaison_cli.storage import resumable_output
    from liaison_cli.scenario.loading import load_scenario
    from liaison_cli.campaign.sweep.manifest import sweep_lock
    from liaison_cli.campaign.sweep.plan import SIGMA_KEY, plan_sweep
    from liaison_cli.campaign.sweep.run import run_sweep

    check_runs(runs)
    fan_out(backend, scheduler, scheduler_timeout)  # before the lock and any work: a bad scheduler is one line
    paths = list(scenario_args or []) + list(scenario_opts or [])
    default_formations = not paths
    if default_formations:
        paths = [scenario_folder(scenarios_dir) / f"{formation}.yaml" for formation in PAPER_FORMATIONS]
    axes = [parse_grid(text) for text in grid or []]
    if sigma is not None:
        axes.insert(0, (SIGMA_KEY, parse_range(sigma, "--sigma")))
    if not axes:
        raise LiaisonError("sweep: nothing to sweep; give --sigma and/or --grid KEY=V1,V2")
    check_grid_size(axes, len(paths), runs)
    bases = [(*load_scenario(path), str(path)) for path in paths]
    if name is None:
        name = "fig15" if default_formations else "+".join(b[0].name for b in bases)
    elif not plain_name(name):
        raise LiaisonError(f"--name {name!r}: a plain name is needed (letters, digits, '_', '-', '+', '.'; no path "
                           "separators, no '..', not starting with '.'); use --output to choose a folder")
    plan = plan_sweep(bases, axes, runs, name)
    out_dir = output or Path("results") / f"sweep-{name}"
    with sweep_lock(out_dir), resumable_output(out_dir, overwrite, plan.key()) as work_dir:
        result = run_sweep(plan, work_dir, backend=backend, jobs=jobs, scheduler=scheduler,
                           progress=not quiet and sys.stderr.isatty(), connect_timeout_s=scheduler_timeout)
    if as_json:
        from liaison_cli.report.json_summary import sweep_document

        echo_json(sweep_document(name, out_dir, [k for k, _ in axes], result.curve_table, len(plan.tasks),
                                 result.computed, result.reused))
    else:
        _print_sweep(result, axes, plan, runs, out_dir)
    curve = result.curve_table
    empty = curve[curve.runs_ok == 0].drop_duplicates("point")
    if len(empty) == curve.point.nunique():
        fail(f"no run of sweep {name} finished healthy (see the manifest's reasons); results kept in {out_dir}",
              EXIT_ALL_DIVERGED)
    if len(empty):
        typer.echo(f"warning: no healthy run at {len(empty)} grid point(s) ({', '.join(map(str, empty.point))}); "
                   "their curve values are empty", err=True)


def _print_sweep(result, axes, plan, runs: int, out_dir: Path) -> None:
    typer.echo(_format_curve(result.curve_table, [k for k, _ in axes]))
    excluded = int(result.curve_table.runs_excluded.sum())
    typer.echo(f"{len(plan.points)} grid points x {runs} runs = {len(plan.tasks)} tasks: {result.computed} computed, "
               f"{result.reused} reused from the manifest"
               + (f"; {excluded} spacecraft-runs diverged or failed and are excluded from the curves"
                  if excluded else ""))
    typer.echo(f"results: {out_dir}")
