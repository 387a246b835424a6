"""The root `liaison` command: its options (--version, -v/--verbose, shell completion) and what runs before
every command (interrupt handling, the `liaison` logger's stderr handler)."""

import logging
import sys

import typer

from liaison_cli import __version__, interrupts
from liaison_cli.cli.group import LiaisonGroup

app = typer.Typer(
    cls=LiaisonGroup,  # flags shown without a value; -v after the command too (cli/group.py)
    add_completion=True,
    no_args_is_help=True,
    help="LiAISON Monte Carlo campaigns: crosslink-only orbit determination in cislunar space.",
)


VERSION_ASKED = "liaison.version_asked"  # ctx.meta key: --version was given


def _ask_for_version(ctx: typer.Context, value: bool) -> None:
    """--version is eager, so it is handled before -v whichever comes first on the line; it only takes note,
    and -v's callback (always run, after every eager option) answers, knowing both."""
    if value and not ctx.resilient_parsing:
        ctx.meta[VERSION_ASKED] = True


def _print_version_if_asked(ctx: typer.Context, verbose: bool) -> bool:
    """After --version: the version, and with -v what the arithmetic ran on (liaison_cli.provenance), one
    `key: value` a line; then exit. Otherwise -v's value, unchanged."""
    if ctx.meta.get(VERSION_ASKED):
        typer.echo(__version__)
        if verbose:
            from liaison_cli.provenance import arithmetic_provenance

            for key, value in arithmetic_provenance().items():
                typer.echo(f"{key}: {value}")
        raise typer.Exit()
    return verbose


@app.callback()
def _configure_process(
    _version: bool = typer.Option(False, "--version", is_eager=True, callback=_ask_for_version,
                                  help="Print the package version and exit; with -v also the library versions, "
                                       "BLAS kernels, CPU and commit behind the arithmetic."),
    verbose: bool = typer.Option(False, "-v", "--verbose", callback=_print_version_if_asked,
                                 help="Also print progress details on stderr (e.g. each stage's time)."),
) -> None:
    """Before every command: Ctrl-C is remembered as well as raised (liaison_cli.interrupts), and messages from
    the library's `liaison` logger go to stderr: warnings as `note: ...` (e.g. a date past the IERS tables),
    and with -v also its info and debug lines (`info: ...`, `debug: ...`)."""
    interrupts.install()
    _install_log_handler(logging.DEBUG if verbose else logging.WARNING)


class _CurrentStderr(logging.StreamHandler):
    """Writes to whatever sys.stderr is at the time of the message (a test runner swaps it per call)."""

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, _value):
        pass


class _LevelPrefix(logging.Formatter):
    """`note: ` for warnings and errors (what a user should read), the level's name for the -v details."""

    def format(self, record: logging.LogRecord) -> str:
        prefix = "note" if record.levelno >= logging.WARNING else record.levelname.lower()
        return f"{prefix}: {record.getMessage()}"


def _install_log_handler(level: int) -> None:
    """One stderr handler on the `liaison` logger per process (CliRunner calls the app many times in one
    process); the level is set on every call, so -v on one command does not leak into the next."""
    logger = logging.getLogger("liaison")
    if not any(getattr(h, "_liaison_notes", False) for h in logger.handlers):
        handler = _CurrentStderr()
        handler.setFormatter(_LevelPrefix())
        handler._liaison_notes = True
        logger.addHandler(handler)
        logger.propagate = False
    logger.setLevel(level)
