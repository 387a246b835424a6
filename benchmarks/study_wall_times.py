"""Wall and CPU seconds of `liaison study003` / `study004` for this checkout and, interleaved, for an earlier
one (issue 25: 003 at 50 runs, 004 at 10 runs per case). Each command runs in its own process from the
checkout's root, so that checkout's package is imported; CPU is user + system of the process and its
workers. On a shared machine read the ratios of neighbouring rows, not the absolute seconds.

    mkdir /tmp/before && git archive <commit> | tar -x -C /tmp/before   # the earlier tree
    python -m benchmarks.study_wall_times --baseline /tmp/before [--rounds 2] [--study 003 --study 004]

The corrected reference orbits of dated scenarios are cached in `~/.cache/liaison/dated-orbits` (this
checkout only): the first study004 after a change to orbits/ or dynamics/ corrects them, later ones read them.
"""

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
COMMANDS = {
    "003": ["study003", "--runs", "50"],
    "004": ["study004", "--runs", "10"],
}


def timed(root: Path, args: list[str]) -> tuple[float, float, int]:
    """(wall s, CPU s of the child and its workers, exit code) of `python -m liaison_cli *args` in root."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        proc = subprocess.run([sys.executable, "-m", "liaison_cli", *args, "--quiet", "--output", f"{out}/r"],
                              cwd=root, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(root)})
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.returncode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="root of the earlier checkout (omit: this one only)")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--study", action="append", choices=sorted(COMMANDS), help="default: every study")
    parser.add_argument("scenarios", nargs="*", help="scenario files for the study (use with one --study; default: its own)")
    args = parser.parse_args()
    roots = [("current", HERE)] + ([("baseline", args.baseline.resolve())] if args.baseline else [])
    print(f"load average at start: {os.getloadavg()[0]:.1f} (a shared machine inflates every row alike)")
    print("| study | checkout | round | wall s | CPU s | exit |")
    print("|---|---|---|---|---|---|")
    for study in args.study or sorted(COMMANDS):
        for round_ in range(1, args.rounds + 1):
            for label, root in (roots if round_ % 2 else roots[::-1]):  # interleaved, alternating who goes first
                wall, cpu, code = timed(root, [*COMMANDS[study], *args.scenarios])
                print(f"| {study} | {label} | {round_} | {wall:.1f} | {cpu:.1f} | {code} |", flush=True)


if __name__ == "__main__":
    main()
