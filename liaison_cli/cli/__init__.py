"""Command-line interface (thin layer: parse, call the campaign and report code, print, map errors to exit
codes), one module per command group. `main` runs the `liaison` command: the Typer `app`, and a clean exit after
Ctrl-C (the entry point, liaison_cli.__main__.run, for the console script and `python -m liaison_cli`, imports
this package).

root.py holds the Typer app and its root options; common.py the exit codes and error mapping every command
shares; each other module registers its commands on `app` when imported here."""

from liaison_cli.cli.root import app
from liaison_cli.cli import (  # noqa: F401  (imported to register their commands, in `--help` order)
    run,
    warmup,
    sweep,
    error_budget,
    design,
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


def main() -> None:
    """Run the `liaison` command and leave cleanly whenever Ctrl-C comes.

    After Ctrl-C (exit 130: the line is printed, nothing is half-written) the exit handlers run (pool and
    semaphore clean-up, llvmlite's shutdown mark) and the process then leaves without the rest of the
    interpreter's teardown: a Ctrl-C that landed while numba compiled can leave LLVM's objects half-built, and
    finalising them crashed the process (SIGSEGV) after its line was printed.

    After the command has finished, the process winds down (the pool's shutdown, the exit handlers) with Ctrl-C
    recorded, not raised, and leaves the same way: the interpreter's own teardown (up to a second, mostly numba's
    and LLVM's objects) used to be where a Ctrl-C killed the process by SIGINT without a line (issue 35, fault
    12). One pressed during the wind-down is one line and exit 130 where the command succeeded; a command that
    failed keeps its own line and code."""
    import typer

    from liaison_cli.cli.common import EXIT_INTERRUPTED, finished_message, interrupt_reported

    try:
        app(prog_name="liaison")
    except KeyboardInterrupt:  # before any command ran (the parser building the command line): nothing written
        _say_interrupted()
        _leave(EXIT_INTERRUPTED)
    except SystemExit as exc:
        code = 0 if exc.code is None else exc.code
        if not isinstance(code, int):  # a message for sys.exit to print: left to the interpreter
            raise
        if code == EXIT_INTERRUPTED and not interrupt_reported():
            _say_interrupted()  # the parser's own Ctrl-C handling: typer exits 130 and prints nothing
        elif code != EXIT_INTERRUPTED and _wind_down() and code == 0:
            typer.echo(f"error: {finished_message()}", err=True)
            code = EXIT_INTERRUPTED
        _leave(code)


def _say_interrupted() -> None:
    """The one line of a Ctrl-C that came before any command's own handling; from now on Ctrl-C is ignored."""
    import typer

    from liaison_cli import interrupts

    interrupts.ignore_from_now_on()
    typer.echo(f"error: {interrupts.INTERRUPTED_MESSAGE}", err=True)


def _wind_down() -> bool:
    """What the interpreter's exit would do first (stop the pool, run the exit handlers), with Ctrl-C recorded;
    afterwards Ctrl-C is ignored (the process only has to leave). True if one came meanwhile."""
    import atexit

    from liaison_cli import interrupts

    caught = interrupts.record_from_now_on()
    _stop_pool_workers()
    atexit._run_exitfuncs()
    _flush_output()
    interrupts.ignore_from_now_on()
    return bool(caught)


def _leave(code: int) -> None:
    """Stop the pool, run the exit handlers (each runs once: after a wind-down none is left), flush, and leave at
    once with `code`, without the interpreter's teardown."""
    import atexit
    import os

    _stop_pool_workers()
    atexit._run_exitfuncs()
    _flush_output()
    os._exit(code)


def _flush_output() -> None:
    import sys

    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (liaison ... | head): nothing more to say there
            pass


def _stop_pool_workers() -> None:
    """Kill loky's reusable pool if this process started one and it is still up (its own exit hook is a
    threading one, which os._exit skips): no worker goes on computing after the prompt is back."""
    import sys

    reusable = sys.modules.get("joblib.externals.loky.reusable_executor")
    executor = getattr(reusable, "_executor", None)
    if executor is not None:
        try:
            executor.shutdown(wait=True, kill_workers=True)
        except Exception:  # noqa: BLE001 - already broken or shut down: nothing left to stop
            pass
