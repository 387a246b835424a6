"""Reading a `liaison run` result folder back (its Parquet tables) for `liaison plot run`: what a folder must
hold to be a run result, and a clear line when it is not."""

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from liaison_cli.errors import LiaisonError, UnreadableFileError

# Written by every `liaison run` (campaign.engine.results.write_outcomes); clocks and bias are empty (no columns)
# when the scenario has no clock states or range biases.
REQUIRED_TABLES = ("summary", "timeseries", "consistency", "residuals")
# The columns the figures read first from each required table: a table without them is another table (issue 47:
# a summary.parquet of some other kind was a traceback).
REQUIRED_COLUMNS = {"summary": ("run", "spacecraft", "status"), "timeseries": ("run", "t_s", "spacecraft"),
                    "consistency": ("t_s", "mean_nees"), "residuals": ("run", "t_s", "link", "innovation")}
OPTIONAL_TABLES = ("clocks", "bias", "links")


@dataclass
class RunResult:
    folder: Path
    name: str                       # the scenario's name (summary metadata), else the folder's name
    summary: pd.DataFrame           # one row per run and spacecraft
    timeseries: pd.DataFrame        # per run, epoch and spacecraft: error and 3-sigma norms, NEES
    consistency: pd.DataFrame       # per epoch: run-averaged NEES and its 95 % band
    residuals: pd.DataFrame         # per run, epoch, link and observable: innovation and its std
    clocks: pd.DataFrame            # per run, epoch and clock: phase and frequency errors and sigmas
    bias: pd.DataFrame              # per run and link: true range bias, estimate, sigma, treatment
    links: pd.DataFrame = None      # per run and channel: NIS after the settle time (older results: empty)
    estimator: str = ""             # the scenario's estimator (summary metadata)
    settle_days: float = float("nan")  # the settle time after which consistency is judged (NaN: older results)


def load_run_result(folder) -> RunResult:
    folder = Path(folder)
    if not folder.is_dir():
        raise LiaisonError(f"{folder}: not a folder; allowed: a result folder written by 'liaison run'")
    missing = [f"{name}.parquet" for name in REQUIRED_TABLES if not (folder / f"{name}.parquet").is_file()]
    if missing:
        raise LiaisonError(f"{folder}: not a 'liaison run' result (no {', '.join(missing)}); allowed: a folder "
                           "written by 'liaison run' (a sweep or study folder holds its own figures)")
    tables = {name: _read(folder / f"{name}.parquet") for name in REQUIRED_TABLES}
    for name, columns in REQUIRED_COLUMNS.items():
        lacking = [c for c in columns if c not in tables[name].columns]
        if lacking:
            raise UnreadableFileError(f"{folder / f'{name}.parquet'}: not the table 'liaison run' writes (no column "
                                      f"{', '.join(lacking)}); rerun the scenario to rebuild it")
    for name in OPTIONAL_TABLES:
        path = folder / f"{name}.parquet"
        tables[name] = _read(path) if path.is_file() else pd.DataFrame()
    name, estimator, settle_days = _scenario_facts(folder)
    return RunResult(folder=folder, name=name, estimator=estimator, settle_days=settle_days, **tables)


def _read(path: Path) -> pd.DataFrame:
    try:
        return pd.read_parquet(path)
    except (OSError, ValueError) as exc:  # pyarrow: ArrowInvalid is a ValueError, ArrowIOError an OSError
        raise UnreadableFileError(f"{path}: not a readable Parquet table ({type(exc).__name__}: "
                                  f"{str(exc).splitlines()[0] if str(exc) else 'no detail'}); rerun the "
                                  "scenario to rebuild it") from None


def _scenario_facts(folder: Path) -> tuple[str, str, float]:
    """(the scenario's name, its estimator, its settle time in days) from the summary's metadata; the folder's
    name, the EKF and NaN when the metadata cannot say (they only title the figures, choose which channels the
    innovations draw and place the settle-time line)."""
    from liaison_cli.estimation.estimators import DEFAULT_ESTIMATOR
    from liaison_cli.storage import read_metadata

    try:
        meta = read_metadata(folder / "summary.parquet")
        estimator = (meta.get("scenario_effective") or {}).get("estimator", DEFAULT_ESTIMATOR)
        settle = meta.get("settle_days")
        return (str(meta.get("scenario_name", folder.name)), str(estimator),
                float(settle) if isinstance(settle, (int, float)) else float("nan"))
    except Exception:  # noqa: BLE001 - see the docstring
        return folder.name, DEFAULT_ESTIMATOR, float("nan")


def highlighted_run(result: RunResult, requested: int | None) -> int:
    """The run drawn in colour: the one asked for, else the first that finished 'ok' (else run 0)."""
    runs = sorted(int(r) for r in result.summary.run.unique())
    if requested is not None:
        if requested not in runs:
            raise LiaisonError(f"--run {requested}: {result.folder} holds runs {runs[0]}-{runs[-1]}")
        return requested
    ok = result.summary[result.summary.status == "ok"]
    return int(ok.run.min()) if len(ok) else runs[0]

