"""What every command shares: exit codes, one-line errors instead of tracebacks, the --runs cap and the
first-compilation notice, the checks on names given on the command line, and the options of every command
that fans runs out (--jobs, --backend, --scheduler, --scheduler-timeout: `fan_out` checks them)."""

import functools
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Annotated

import typer

from liaison_cli import interrupts
from liaison_cli.errors import LiaisonError

EXIT_OS_ERROR = 4  # an operating-system fault while reading or writing files
EXIT_ALL_DIVERGED = 5  # the campaign ran, but no run finished healthy
EXIT_INTERRUPTED = 130  # Ctrl-C (128 + SIGINT, as a shell reports it)
INTERRUPTED_MESSAGE = interrupts.INTERRUPTED_MESSAGE


def _interrupted_message() -> str:
    written = interrupts.written()
    if written:
        return (f"interrupted after the result was written: {', '.join(written)} is complete; only the printed "
                "summary was cut short")
    return INTERRUPTED_MESSAGE


def finished_message() -> str:
    """The line for a Ctrl-C that came after the command had finished (cli.main, while the process winds down)."""
    written = interrupts.written()
    if written:
        return f"interrupted after the result was written: {', '.join(written)} is complete, and so is the output above"
    return "interrupted after the command had finished: its output above is complete"


_interrupt_reported = False  # cli.main: a silent exit 130 (typer's own Ctrl-C handling) still gets its line


def fail(message: str, code: int) -> None:
    global _interrupt_reported
    typer.echo(f"error: {message}", err=True)
    _interrupt_reported = _interrupt_reported or code == EXIT_INTERRUPTED
    raise typer.Exit(code)


def interrupt_reported() -> bool:
    """This process has printed its "interrupted" line (fail with EXIT_INTERRUPTED)."""
    return _interrupt_reported


# The parser's usage errors: click's ClickException, which typer re-exports or (from 0.2x) vendors.
_PARSER_ERROR = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")


def user_errors(func):
    """Turn typed errors into a one-line message and their exit code; never a traceback."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except LiaisonError as exc:
            if exc.exit_code == EXIT_INTERRUPTED:  # a sweep's own "interrupted: N of M tasks saved" line
                interrupts.ignore_from_now_on()
            fail(str(exc), exc.exit_code)
        except KeyboardInterrupt:
            interrupts.ignore_from_now_on()  # nothing may turn exit 130 into death by SIGINT now
            fail(_interrupted_message(), EXIT_INTERRUPTED)
        except OSError as exc:  # disk full, read-only, not a directory, permission: the path and the cause
            if interrupts.caused_by_interrupt(exc):
                interrupts.ignore_from_now_on()
                fail(_interrupted_message(), EXIT_INTERRUPTED)
            where = exc.filename if exc.filename is not None else "file system"
            fail(f"{where}: {exc.strerror or exc}", EXIT_OS_ERROR)
        except (typer.Exit, typer.Abort, _PARSER_ERROR):
            raise  # a command's own exit code and the parser's usage errors stay as they are
        except Exception as exc:  # noqa: BLE001 - only what a Ctrl-C caused; anything else is re-raised
            # A Ctrl-C inside compiled code comes back as a SystemError; one that lands while numba compiles
            # (a cold cache) is swallowed by an LLVM callback and surfaces later as numba's RuntimeError ("no
            # compiled object yet"). The remembered request (interrupts.requested) tells them apart.
            if not interrupts.caused_by_interrupt(exc):
                raise
            logging.getLogger("liaison").info("after Ctrl-C: %s: %s", type(exc).__name__, exc)  # -v shows it
            interrupts.ignore_from_now_on()
            fail(_interrupted_message(), EXIT_INTERRUPTED)

    return wrapper


def check_runs(runs, option: str = "--runs") -> None:
    """--runs (errors: --check-runs) obeys the same cap as the scenario's monte_carlo.runs. Every command that
    runs filters calls this first, so it is also where the first-compilation notice is armed."""
    from liaison_cli.scenario.estimation_settings import MAX_RUNS

    if runs is not None and runs > MAX_RUNS:
        raise LiaisonError(f"{option} {runs}: at most {MAX_RUNS:,} runs (the cap of monte_carlo.runs)")
    _announce_compilation()


# One constant line (tests match it whole). Its figures are measured, by benchmarks/first_runs.py
# (results/reference/first_runs.md): a first run's wall time from an empty cache, which is mostly compiling.
COMPILE_NOTICE = ("liaison: compiling the numeric core, once per machine and liaison version, then cached (a "
                  "first-ever run took 40-62 s on a shared 2-core machine; every scenario shares most of it, so a "
                  "later kind of scenario or command compiles for 0-10 s); `liaison warm-up` compiles it all ahead")


@functools.cache  # one listener per process, however many commands run in it
def _announce_compilation() -> None:
    """One line on stderr (a `note:` of the `liaison` logger) when numba starts compiling liaison code (a cache
    miss), so a new user knows why the first run is slow. Loading from the cache is not compiling and stays
    silent."""
    from numba.core import event

    class Notice(event.Listener):
        shown = False

        def on_start(self, ev):
            function = getattr(ev.data.get("dispatcher"), "py_func", None)
            if not Notice.shown and getattr(function, "__module__", "").startswith("liaison_cli"):
                Notice.shown = True
                logging.getLogger("liaison").warning(COMPILE_NOTICE)  # through -v's logger, as a note

        def on_end(self, ev):
            pass

    event.register("numba:compile", Notice())


def plain_name(name: str) -> bool:
    """A sweep name becomes a folder under results/: it may not climb out of it or hide."""
    import re

    return bool(re.fullmatch(r"[A-Za-z0-9_+\-][A-Za-z0-9_+.\-]*", name)) and ".." not in name


def check_file_output(path: Path, overwrite: bool, option: str, what: str, ours: Callable[[Path], bool]) -> None:
    """A file a command writes whole (`schema --output`, `tune --table` and its Parquet), checked before any work:
    the rule of result folders (storage.ownership) for one file. A missing file is written; an existing one is
    replaced when `ours` proves it this command's earlier output (by its content, never its name: a rerun), or
    with --overwrite; a directory or a special file never. Anything else: one line, exit 2."""
    from liaison_cli.errors import OutputExistsError

    if path.is_dir() or (path.exists() and not path.is_file()):
        raise OutputExistsError(f"{path} ({option}): {'a directory' if path.is_dir() else 'not a regular file'}; "
                                f"allowed: a file path for {what}")
    if not (path.exists() or path.is_symlink()) or overwrite or ours(path):
        return
    raise OutputExistsError(f"{path} ({option}): a file liaison did not write as {what} already exists; pass "
                            "--overwrite to replace it or choose another path")


def file_starts_with(path: Path, texts: tuple[str, ...], limit_bytes: int = 4096) -> bool:
    """The file's first `limit_bytes` hold each of `texts` (an ownership check reads no more, whatever the file)."""
    try:
        with open(path, "rb") as handle:
            head = handle.read(limit_bytes).decode("utf-8", errors="replace")
    except OSError:
        return False
    return all(text in head for text in texts)


def refuse_repeated_labels(labelled: list, what: str) -> None:
    """labelled: [(path, label)]; a label given twice is one line naming the second file."""
    first: dict = {}
    for path, label in labelled:
        if label in first:
            raise LiaisonError(f"{path}: {what} {label!r} is also that of {first[label]}; allowed: scenarios with "
                               f"distinct {what}s (each labels its own rows, metadata and figures)")
        first[label] = path



def json_option():
    """The `--json` flag of the commands with a machine-readable summary (keys: docs/json-output.md)."""
    return typer.Option(False, "--json", help="print a machine-readable JSON summary instead of the text "
                                              "(keys: docs/json-output.md); errors stay one line on stderr")


def echo_json(document: dict) -> None:
    from liaison_cli.report.json_summary import to_json_text

    typer.echo(to_json_text(document))


# --- The fan-out options of every long command (run, compare, table3, sweep, tune, errors, study003/004) -------
# Declared once, as annotated aliases; each command lists them in this order, with these defaults:
#     jobs: JobsOption = 2, backend: BackendOption = "joblib", scheduler: SchedulerOption = None,
#     scheduler_timeout: SchedulerTimeoutOption = 20.0
# and hands backend, scheduler and scheduler_timeout to `fan_out` (--quiet: QuietOption, below).
JobsOption = Annotated[int, typer.Option("--jobs", min=1,
                                         help="worker processes (joblib) or LocalCluster workers (dask)")]
BackendOption = Annotated[str, typer.Option("--backend", help="joblib (local processes) or dask (dask.distributed)")]
SchedulerOption = Annotated[str, typer.Option("--scheduler", help="dask scheduler address, e.g. tcp://host:8786 "
                                              "(default with --backend dask: a LocalCluster of --jobs workers)")]
SchedulerTimeoutOption = Annotated[float, typer.Option("--scheduler-timeout", min=0.1,
                                                       help="seconds to wait for the dask scheduler")]


def fan_out(backend: str, scheduler: str | None, scheduler_timeout_s: float, connect: bool = True):
    """The backend the options name (campaign.engine.backends.Backend), checked before any work: an unknown backend or
    a malformed address is one line, exit 2; a scheduler that does not answer within the timeout, exit 3.
    connect=False skips asking the scheduler, for a command that will not use it this time (`errors`
    without --check-runs)."""
    from liaison_cli.campaign.engine.backends import Backend, check_backend, check_scheduler_address, probe_scheduler

    check_backend(backend, scheduler)
    if scheduler and connect:
        probe_scheduler(scheduler, scheduler_timeout_s)  # checks the address first
    elif scheduler:
        check_scheduler_address(scheduler)
    return Backend(backend, scheduler, scheduler_timeout_s)


# --- Options several commands share (run, sweep, tune, errors, the studies, orbits) ----------------------
# Annotated aliases: each command keeps its own default in its signature (`quiet: QuietOption = False`).
QuietOption = Annotated[bool, typer.Option("--quiet", help="no progress bar")]
StudyOverwriteOption = Annotated[bool, typer.Option("--overwrite", help="replace an earlier study there")]
StudyGridOption = Annotated[list[str], typer.Option(
    "--grid", help="KEY=V1,V2: repeat the study over filter settings (e.g. filter.underweighting=0,0.2); "
    "repeatable")]
FamilyArgument = Annotated[str, typer.Argument(help="family name (see 'liaison orbits list')")]
FamilyCountOption = Annotated[int, typer.Option("--count", min=2, max=500,
                                                help="members (generated if not cached, then stored)")]
