"""Command-line interface (thin layer: parse, call the campaign and report code, print, map errors to exit
codes), one module per command group. `app` is the `liaison` entry point (pyproject: liaison_cli.cli:app).

root.py holds the Typer app and its root options; common.py the exit codes and error mapping every command
shares; each other module registers its commands on `app` when imported here."""

from liaison_cli.cli.root import app
from liaison_cli.cli import (  # noqa: F401  (imported to register their commands, in `--help` order)
    run,
    sweep,
    error_budget,
    studies,
    plot,
    budget,
    orbits,
    geometry,
    scenario_files,
    exchange,
    tuning,
)

__all__ = ["app", "main"]


def main():  # pragma: no cover - console entry point
    app()
