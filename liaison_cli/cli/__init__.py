"""Command-line interface (thin layer: parse, call the campaign and report code, print, map errors to exit
codes), one module per command group. `main` is the `liaison` entry point (pyproject: liaison_cli.cli:main,
and `python -m liaison_cli`): the Typer `app`, and a clean exit after Ctrl-C.

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


def main() -> None:
    """Run the `liaison` command. After Ctrl-C (exit 130: the line is printed, nothing is half-written) the
    exit handlers run (pool and semaphore clean-up, llvmlite's shutdown mark) and the process then leaves
    without the rest of the interpreter's teardown: a Ctrl-C that landed while numba compiled can leave LLVM's
    objects half-built, and finalising them crashed the process (SIGSEGV) after its line was printed."""
    import atexit
    import os
    import sys

    from liaison_cli.cli.common import EXIT_INTERRUPTED

    try:
        app(prog_name="liaison")
    except SystemExit as exc:
        if exc.code == EXIT_INTERRUPTED:
            _stop_pool_workers()
            atexit._run_exitfuncs()
            for stream in (sys.stdout, sys.stderr):
                try:
                    stream.flush()
                except (OSError, ValueError):  # a closed pipe (liaison ... | head): nothing more to say there
                    pass
            os._exit(EXIT_INTERRUPTED)
        raise


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
