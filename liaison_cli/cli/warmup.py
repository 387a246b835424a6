"""`liaison warm-up`: compile every kernel specialisation the shipped scenarios and templates need, ahead of
the first run (the work is liaison_cli.campaign.engine.warmup; this module parses, calls and prints)."""

import os
import tempfile
import time

import typer

from liaison_cli.cli.common import user_errors
from liaison_cli.cli.root import app
from liaison_cli.errors import LiaisonError

EXIT_WARM_UP_FAILED = 1  # a combination's run failed: its kernels may be missing from the cache


@app.command("warm-up")
@user_errors
def warm_up(
    # Text, checked here: 0, -1 or x get the one-line refusal every bad input gets, not the parser's box.
    jobs: str = typer.Option("2", "--jobs", metavar="N", help="processes compiling side by side (a whole number, "
                             "1 or more; more than the combinations buys nothing)"),
    list_only: bool = typer.Option(False, "--list", help="print the combinations and the scenarios each stands "
                                   "for, and compile nothing"),
    cache_dir: str = typer.Option(None, "--cache-dir", metavar="DIR", help="compile into this cache folder "
                                  "instead of the user's (default: $LIAISON_CACHE_DIR, else ~/.cache/liaison); "
                                  "runs with LIAISON_CACHE_DIR=DIR load from it, on any machine of the same "
                                  "architecture and Python"),
):
    """Compile the numeric core every shipped scenario and template needs, ahead: one small run per combination
    of estimator, dynamics and observables; their first runs then load it from the cache. Writes nothing else.

    Examples: liaison warm-up --jobs 2; liaison warm-up --list (what it would compile, for which scenarios);
    liaison warm-up --cache-dir liaison-cache (then LIAISON_CACHE_DIR=$PWD/liaison-cache liaison run ..., on a
    shared disk for a team)"""
    n_jobs = _whole_number(jobs, "--jobs")
    if not list_only:  # a folder it cannot write: its path and the cause (exit 4), before minutes of compiling
        _writable(cache_dir if cache_dir is not None else os.environ["NUMBA_CACHE_DIR"])
    if cache_dir is not None:  # before anything compiled is imported: numba fixes a function's folder then
        from liaison_cli import use_cache_dir

        try:
            use_cache_dir(cache_dir)
        except RuntimeError as exc:  # a Python session that has compiled liaison code already
            raise LiaisonError(f"--cache-dir {cache_dir}: this process already uses the cache "
                               f"{os.environ['NUMBA_CACHE_DIR']}; allowed: --cache-dir from the command line, or "
                               "LIAISON_CACHE_DIR set before Python starts") from exc
    from liaison_cli.campaign.engine.warmup import COMMANDS, WARM_UP_DAYS, compiling_ahead_of_the_plan, plan

    with compiling_ahead_of_the_plan(1 if list_only else n_jobs):  # the plan's reading beside compiling
        specs = plan()
        runs = [spec for spec in specs if spec.command == "run"]
        n_sources = sum(len(spec.sources) for spec in runs)
        if list_only:
            typer.echo(f"{len(runs)} combinations (estimator · dynamics, then the observables their scenarios use) "
                       f"for {n_sources} shipped scenarios and templates; warm-up runs the first scenario of each, "
                       f"cut to 1 run over at most {WARM_UP_DAYS:g} d, and sets up the others over a few epochs; "
                       f"then {' and '.join(f'`liaison {c}`' for c in COMMANDS)} once:")
            for spec in specs:
                typer.echo(_wrapped(f"{spec.name}: ", [source.label for source in spec.sources]))
            return
        _compile_all(specs, n_sources, n_jobs)


def _writable(folder: str) -> None:
    """Create `folder` and write a temporary file in it, or raise the OSError (its path and cause)."""
    os.makedirs(folder, exist_ok=True)
    tempfile.TemporaryFile(dir=folder).close()


def _wrapped(head: str, items: list[str], width: int = 110) -> str:
    """head and the items, comma-separated, in lines of at most `width` where it can: a file name or
    `template KIND` is never split, so each can be searched for whole."""
    lines, line = [], head
    for i, item in enumerate(items):
        piece = item + ("," if i + 1 < len(items) else "")
        if len(line) + len(piece) > width and line.strip():
            lines.append(line.rstrip())
            line = "    "
        line += piece + " "
    return "\n".join([*lines, line.rstrip()])


def _whole_number(text: str, option: str) -> int:
    """The option as a whole number of at least 1, or one line naming it, its value and what is allowed."""
    import re

    if not re.fullmatch(r"[0-9]+", text.strip()) or int(text) < 1:
        raise LiaisonError(f"{option} {text!r}: not allowed; allowed: a whole number of processes, 1 or more (e.g. "
                           f"{option} 2)")
    return int(text)


def _compile_all(specs, n_sources: int, jobs: int) -> None:
    from liaison_cli.campaign.engine.warmup import warm_up

    cache = os.environ.get("NUMBA_CACHE_DIR", "")
    n_runs = sum(spec.command == "run" for spec in specs)
    typer.echo(f"warm-up: {n_runs} combinations for {n_sources} shipped scenarios and templates and "
               f"{len(specs) - n_runs} commands, "
               f"{min(jobs, len(specs))} process(es); cache {cache}")
    started = time.perf_counter()
    results = []
    for result in warm_up(specs, jobs):
        results.append(result)
        typer.echo(_result_line(result))
    seconds = time.perf_counter() - started
    signatures = [s for result in results for s in result.signatures]
    twice = len(signatures) - len(set(signatures))  # processes side by side that both missed the cache
    again = f" ({twice} compiled twice, by processes side by side)" if twice else ""
    from liaison_cli.campaign.engine.warmup import verify

    missing = verify(results)
    if missing:
        typer.echo(f"error: {len(missing)} of the {len(signatures)} compiled functions cannot be read back from the "
                   f"cache {cache} (a full disk, or a folder another process writes?): {', '.join(missing[:3])}"
                   + (" ..." if len(missing) > 3 else ""), err=True)
        raise typer.Exit(EXIT_WARM_UP_FAILED)
    if signatures:
        typer.echo(f"warm-up: compiled {len(signatures)} functions in {seconds:.1f} s{again}, each read back from "
                   "the cache; a first run of any shipped scenario or template, `liaison errors` and "
                   "`liaison observability` now load their code from it")
    else:
        typer.echo(f"warm-up: nothing to compile, every combination was cached ({seconds:.1f} s)")
    failed = [result for result in results if result.error]
    if failed:
        typer.echo(f"error: {len(failed)} of {len(results)} combinations failed (above); their code may be "
                   "compiled at their first run", err=True)
        raise typer.Exit(EXIT_WARM_UP_FAILED)


def _result_line(result) -> str:
    spec = result.specialisation
    others = len(spec.sources) - 1
    verb = "ran" if spec.command == "run" else "on"
    ran = f"{verb} {spec.representative.label}" + (f", set up {others} more" if others else "")
    if result.error:
        return f"{spec.name}: FAILED after {result.seconds:.1f} s ({ran}): {result.error}"
    if not result.compiled:
        return f"{spec.name}: nothing new to compile, already cached ({result.seconds:.1f} s; {ran})"
    return f"{spec.name}: compiled {len(result.compiled)} functions in {result.seconds:.1f} s ({ran})"
