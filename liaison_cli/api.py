"""The stable Python API: what `liaison run`, `sweep` and `export` do, as functions (docs/python-api.md).

    from liaison_cli import api
    scenario = api.load("eml2_lunar", {"noise.sigma_m": 300})   # a file, or a shipped scenario's name
    result = api.run(scenario, runs=4)                             # in memory; api.summary(result) -> DataFrame
    api.write(result, "results/mine-4")                            # ... and its folder, as `liaison run` writes it
    folder = api.run_to_folder(scenario, "results/mine", runs=20)  # the folder `liaison run` writes
    curve = api.sweep([scenario], {"noise.sigma_m": [100, 200]}, runs=5, output="results/sw")
    files = api.export("results/mine", run=0, frame="icrf", epoch="2030-01-01T00:00:00")

These names and their keyword arguments are the contract: they change only with a new major version (a test
holds their signatures). Everything else in liaison_cli is internal and may change. Every argument is checked
before any work: a wrong type or value raises ArgumentError (a LiaisonError that is also a ValueError and a
TypeError) whose one-line message names the argument, what was given and what is allowed; problems with a
scenario or a file raise the same LiaisonError types the CLI maps to its exit codes (liaison_cli.errors).
"""

import numbers
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

from liaison_cli.errors import LiaisonError

__all__ = ["ArgumentError", "export", "load", "provenance", "read_table", "run", "run_to_folder", "summary",
           "sweep", "timeseries", "write"]

EXPORT_FORMATS = ("kvn", "xml")


class ArgumentError(LiaisonError, ValueError, TypeError):
    """A Python API argument of the wrong type or value (the message names it, the value and what is allowed)."""


def _shown(value) -> str:
    """A value as a message shows it: its repr, cut to 60 characters, with its type."""
    text = repr(value)
    return f"{text[:57]}... ({type(value).__name__})" if len(text) > 60 else f"{text} ({type(value).__name__})"


def _path_like(name: str, value) -> Path:
    if isinstance(value, (str, os.PathLike)) and str(value):
        return Path(value)
    raise ArgumentError(f"{name}: {_shown(value)}; allowed: a path (str or os.PathLike)")


def _count(name: str, value, optional: bool = False):
    if optional and value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise ArgumentError(f"{name}: {_shown(value)}; allowed: a whole number, 1 or more" + (" (or None)" if optional else ""))
    return int(value)


def _flag(name: str, value) -> bool:
    if not isinstance(value, bool):
        raise ArgumentError(f"{name}: {_shown(value)}; allowed: True or False")
    return value


def _scenario(value):
    """A validated Scenario: as given, or loaded from a path or a shipped name."""
    from liaison_cli.scenario.scenario_model import Scenario

    if isinstance(value, Scenario):
        return value
    if isinstance(value, (str, os.PathLike)):
        return load(value)
    raise ArgumentError(f"scenario: {type(value).__name__} given; allowed: a Scenario (api.load), a scenario file's "
                        "path or a shipped scenario's name")


def load(scenario, overrides: Mapping | None = None):
    """The validated Scenario of a YAML file or of a shipped scenario's name ("eml2_lunar", "004/dro"), as `liaison
    run` reads it, with dotted keys overridden ({"noise.sigma_m": 300}; None removes a key so its default applies)."""
    from liaison_cli.scenario.loading import apply_overrides, load_scenario

    config, _ = load_scenario(_path_like("scenario", scenario))
    if overrides is None:
        return config
    if not isinstance(overrides, Mapping) or not all(isinstance(key, str) for key in overrides):
        raise ArgumentError(f"overrides: {_shown(overrides)}; allowed: a mapping of dotted scenario keys to values")
    return apply_overrides(config, dict(overrides), "overrides")


def run(scenario, runs: int | None = None, jobs: int = 1, progress: bool = False):
    """Run the scenario's Monte Carlo campaign in memory: a CampaignResult (its `outcomes`, one per run; tables by
    summary(result) and timeseries(result)). runs: default the scenario's; jobs: processes (a run's numbers never
    depend on them)."""
    from liaison_cli.campaign.engine.runner import run_campaign

    config = _scenario(scenario)
    return run_campaign(config, _count("runs", runs, optional=True), _count("jobs", jobs), _flag("progress", progress))


def run_to_folder(scenario, output, runs: int | None = None, jobs: int = 2, overwrite: bool = False,
                  progress: bool = False) -> Path:
    """Run the campaign and write the folder `liaison run --output OUTPUT` writes, as the runs finish (memory does
    not grow with the run count), built beside it and moved into place whole; an existing liaison result there is
    replaced only with overwrite. Returns the folder."""
    from liaison_cli.campaign.engine.results import stream_campaign
    from liaison_cli.campaign.studies.output import fill_folder

    config = _scenario(scenario)
    folder = _path_like("output", output)
    runs, jobs = _count("runs", runs, optional=True), _count("jobs", jobs)
    overwrite, progress = _flag("overwrite", overwrite), _flag("progress", progress)
    text = _scenario_text(scenario, config)
    fill_folder(folder, overwrite, lambda stage: stream_campaign(config, stage, text, runs=runs, jobs=jobs,
                                                                  progress=progress))
    return folder


def _scenario_text(given, config) -> str:
    """The YAML text a result folder keeps as scenario.yaml: the file's own when a path was given, else the
    validated scenario written out."""
    if isinstance(given, (str, os.PathLike)):
        from liaison_cli.scenario.loading import read_scenario_text, scenario_file

        return read_scenario_text(scenario_file(given))[1]
    import yaml

    return yaml.safe_dump(config.model_dump(mode="json", exclude_none=True, exclude={"topology"}), sort_keys=False)


def write(result, folder, overwrite: bool = False) -> Path:
    """The folder `liaison run` writes, from a run() result held in memory (its scenario.yaml: the scenario run,
    written out), built beside `folder` and moved into place whole. Returns the folder."""

    from liaison_cli.campaign.engine.results import write_campaign
    from liaison_cli.campaign.studies.output import fill_folder

    campaign, folder = _result(result), _path_like("folder", folder)
    text = _scenario_text(campaign.scenario, campaign.scenario)
    fill_folder(folder, _flag("overwrite", overwrite), lambda stage: write_campaign(campaign, stage, text))
    return folder


def summary(result):
    """One row per run and spacecraft of a run() result (summary.parquet's columns)."""
    from liaison_cli.campaign.engine.results import summary_table

    return summary_table(_result(result))


def timeseries(result):
    """One row per run, epoch and spacecraft of a run() result (timeseries.parquet's columns)."""
    from liaison_cli.campaign.engine.results import timeseries_table

    return timeseries_table(_result(result))


def _result(value):
    from liaison_cli.campaign.engine.runner import CampaignResult

    if not isinstance(value, CampaignResult):
        raise ArgumentError(f"result: {type(value).__name__} given; allowed: what api.run returns")
    return value


def read_table(folder, table: str = "summary"):
    """A table of a result folder any command wrote (`summary`, `timeseries`, `curve`, ...) as a DataFrame."""
    import pandas as pd

    from liaison_cli.errors import UnreadableFileError

    path = _table_path(folder, table)
    try:
        return pd.read_parquet(path)
    except (OSError, ValueError) as exc:
        raise UnreadableFileError(f"{path}: cannot read it ({type(exc).__name__})") from None


def _table_path(folder, table) -> Path:
    """FOLDER/TABLE.parquet, which must exist (else one line listing the folder's tables)."""
    folder = _path_like("folder", folder)
    if not isinstance(table, str) or not table or "/" in table or "\\" in table or table.startswith("."):
        raise ArgumentError(f"table: {_shown(table)}; allowed: the stem of a Parquet file in the folder (e.g. 'summary')")
    path = folder / f"{table}.parquet"
    if not path.is_file():
        raise ArgumentError(f"table: {table!r}: {path} does not exist; allowed: "
                            + (", ".join(sorted(p.stem for p in folder.glob("*.parquet"))) or "a result folder"))
    return path


def provenance(folder, table: str = "summary") -> dict:
    """What a result table records of how it was made (its Parquet metadata: scenario_effective, seed, runs,
    package_version, the arithmetic; docs/outputs.md)."""
    from liaison_cli.storage import read_metadata

    return read_metadata(_table_path(folder, table))


def sweep(scenarios, grid: Mapping, output, runs: int = 10, jobs: int = 2, name: str | None = None,
          overwrite: bool = False, progress: bool = False):
    """`liaison sweep`: every scenario at every point of the full-factorial grid ({dotted key: [values]}), `runs`
    runs each, into the resumable folder `output` (a finished task is never recomputed; overwrite starts it
    afresh). Returns the curve table (curve.parquet: per point and spacecraft, the statistics the sweep prints)."""
    from liaison_cli.campaign.sweep.grid import check_grid_size
    from liaison_cli.campaign.sweep.manifest import sweep_lock
    from liaison_cli.campaign.sweep.plan import plan_sweep
    from liaison_cli.campaign.sweep.run import run_sweep
    from liaison_cli.storage import resumable_output

    if isinstance(scenarios, (str, os.PathLike)) or not isinstance(scenarios, Sequence) or not scenarios:
        raise ArgumentError(f"scenarios: {_shown(scenarios)}; allowed: a non-empty list of Scenarios, paths or names")
    if not isinstance(grid, Mapping) or not grid or not all(
            isinstance(k, str) and isinstance(v, Sequence) and not isinstance(v, str) and len(v) for k, v in grid.items()):
        raise ArgumentError(f"grid: {_shown(grid)}; allowed: a mapping of dotted scenario keys to non-empty lists of values")
    runs, jobs = _count("runs", runs), _count("jobs", jobs)
    folder = _path_like("output", output)
    overwrite, progress = _flag("overwrite", overwrite), _flag("progress", progress)
    axes = [(key, list(values)) for key, values in grid.items()]
    check_grid_size(axes, len(scenarios), runs)

    bases = []
    for given in scenarios:
        config = _scenario(given)
        source = str(given) if isinstance(given, (str, os.PathLike)) else f"<{config.name}>"
        bases.append((config, _scenario_text(given, config), source))
    from liaison_cli.cli.common import plain_name

    if name is not None and not (isinstance(name, str) and plain_name(name)):
        raise ArgumentError(f"name: {_shown(name)}; allowed: a plain name (letters, digits, '_', '-', '+', '.'; no path "
                            "separators, no '..') or None")
    plan = plan_sweep(bases, axes, runs, name or "+".join(base[0].name for base in bases))
    with sweep_lock(folder), resumable_output(folder, overwrite, plan.key()) as work_dir:
        result = run_sweep(plan, work_dir, jobs=jobs, progress=progress)
    return result.curve_table


def export(result_folder, run: int = 0, output=None, formats: Sequence[str] = ("kvn",), frame: str | None = None,
           epoch: str | None = None, centre: str = "earth", overwrite: bool = False) -> list[Path]:
    """`liaison export`: run `run` of a `liaison run` result folder as CCSDS OEMs (truth; estimate with covariance)
    and a TDM, into output (default RESULT_FOLDER/ccsds-run<run>); frame "icrf" with epoch (a TDB date) carries a
    CRTBP run into ICRF about the Earth or the Moon (docs/exchange.md). Returns the files written."""
    from liaison_cli.campaign.exchange.export import FrameRequest, check_export_request, export_run, parse_epoch
    from liaison_cli.campaign.studies.output import fill_folder
    from liaison_cli.errors import ExchangeFileError

    folder = _path_like("result_folder", result_folder)
    if isinstance(run, bool) or not isinstance(run, numbers.Integral) or run < 0:
        raise ArgumentError(f"run: {_shown(run)}; allowed: a whole number, 0 or more")
    if isinstance(formats, str) or not isinstance(formats, Sequence) or not formats or any(
            f not in EXPORT_FORMATS for f in formats):
        raise ArgumentError(f"formats: {_shown(formats)}; allowed: a list of some of {', '.join(EXPORT_FORMATS)}")
    formats = tuple(formats)
    if frame not in (None, "rotating", "icrf") or centre not in ("earth", "moon"):
        raise ArgumentError(f"frame, centre: {frame!r}, {centre!r}; allowed: frame None, 'rotating' or 'icrf'; "
                            "centre 'earth' or 'moon'")
    try:
        seconds, text = parse_epoch(epoch) if epoch is not None else (None, None)
    except ExchangeFileError:
        raise ArgumentError(f"epoch: {_shown(epoch)}; allowed: a TDB date 'YYYY-MM-DDThh:mm:ss[.d]' or None") from None
    out = folder / f"ccsds-run{run}" if output is None else _path_like("output", output)
    check_export_request(folder, out)  # a result folder, and not the export's own target: before anything is made
    request = FrameRequest(frame, seconds, text, centre.upper())
    done = fill_folder(out, _flag("overwrite", overwrite),
                       lambda stage: export_run(folder, int(run), formats, stage, request))
    return [out / name for name in done["files"]]
