"""The root `liaison` command: its options (--version, -v) and what runs before every command."""

import sys

import typer

from liaison_cli import __version__, interrupts

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

