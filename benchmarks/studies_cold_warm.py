"""Studies from an empty cache and from a warm one (issue 37, item 3): `liaison study004 --runs 10` and
`liaison study003`, each in a new process, wall seconds start to exit, and where the time went.

    python benchmarks/studies_cold_warm.py [--code before=/path/to/checkout --code after=/work/main]
                                           [--study study004 --study study003] [--output results/reference/...]

Each `--code LABEL=PATH` is a folder holding a `liaison_cli` package (a snapshot of another checkout: before /
after side by side); the default is this checkout. For every study the cases run interleaved (code A cold, code
B cold, code A warm, code B warm), so the load of a shared machine falls on both alike. *Cold*: a fresh
LIAISON_CACHE_DIR (no compiled kernels, no corrected orbits, no family tables); *warm*: the same folder again,
right after.

The split comes from timers installed in the command's own (parent) process: *compile* is what numba compiled
(its `numba:compile` events, outermost only), *orbits* the multiple-shooting corrections into the dated model
(orbits.corrected_store's corrected_in_stages, less the compiling inside it), *start* the imports before the
command runs, and *rest* everything else (truth, measurements and the Monte Carlo runs, in the parent and the
workers, tables and figures). Workers load the kernels the parent compiled; what a worker compiles itself (none
expected) would fall in *rest*. The markdown table goes to results/reference/studies_cold_warm.md.
"""

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STUDIES = {"study004": ["study004", "--runs", "10"], "study003": ["study003"]}

# Runs in the child: timers around the command, then `liaison ARGS`; the split goes to $LIAISON_BENCH_TIMES.
CHILD = r"""
import json, os, sys, time, atexit
t0 = time.perf_counter()
from numba.core import event
times = {"compile": 0.0, "orbits": 0.0, "compile_in_orbits": 0.0}
depth = [0]
in_orbits = [False]

class Timer(event.Listener):
    def on_start(self, ev):
        if depth[0] == 0:
            self.started = time.perf_counter()
        depth[0] += 1
    def on_end(self, ev):
        depth[0] -= 1
        if depth[0] == 0:
            spent = time.perf_counter() - self.started
            times["compile"] += spent
            if in_orbits[0]:
                times["compile_in_orbits"] += spent

event.register("numba:compile", Timer())
import liaison_cli.orbits.corrected_store as store
original = store.corrected_in_stages
def corrected_in_stages(*args, **kwargs):
    started = time.perf_counter()
    in_orbits[0] = True
    try:
        return original(*args, **kwargs)
    finally:
        in_orbits[0] = False
        times["orbits"] += time.perf_counter() - started
store.corrected_in_stages = corrected_in_stages
from liaison_cli.cli import main
times["start"] = time.perf_counter() - t0

@atexit.register
def write():
    times["orbits"] -= times.pop("compile_in_orbits")
    with open(os.environ["LIAISON_BENCH_TIMES"], "w") as handle:
        json.dump(times, handle)

sys.argv = ["liaison", *sys.argv[1:]]
main()
"""


def run_case(code: Path, cache: Path, args: list[str]) -> dict:
    """One command in a new process: wall seconds, exit code, load at its start, and the split."""
    with tempfile.TemporaryDirectory() as folder:
        times_path = Path(folder) / "times.json"
        env = {**os.environ, "LIAISON_CACHE_DIR": str(cache), "PYTHONPATH": str(code),
               "LIAISON_BENCH_TIMES": str(times_path)}
        load = os.getloadavg()[0]
        t0 = time.perf_counter()
        # cwd: `python -c` puts the working folder first on sys.path, before PYTHONPATH (a checkout's liaison_cli)
        done = subprocess.run([sys.executable, "-c", CHILD, *args, "--output", f"{folder}/out"], env=env, cwd=folder,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        wall = time.perf_counter() - t0
        split = json.loads(times_path.read_text()) if times_path.exists() else {}
    if done.returncode:
        print(done.stderr[-2000:], file=sys.stderr)
    split["rest"] = wall - sum(split.get(k, 0.0) for k in ("start", "compile", "orbits"))
    return {"wall": wall, "exit": done.returncode, "load": load, **split}


def cell(case: dict) -> str:
    parts = ", ".join(f"{k} {case[k]:.1f}" for k in ("start", "compile", "orbits", "rest") if k in case)
    failed = "" if case["exit"] == 0 else f", exit {case['exit']}"
    return f"{case['wall']:.1f} s ({parts}; load {case['load']:.1f}{failed})"


def measure(codes: dict, studies: list[str]) -> list[tuple[str, str, str, dict]]:
    rows = []
    for study in studies:
        caches = {label: Path(tempfile.mkdtemp(prefix=f"liaison-{study}-{label}-")) for label in codes}
        try:
            for state in ("cold", "warm"):
                for label, code in codes.items():
                    case = run_case(code, caches[label], STUDIES[study])
                    print(f"{study} {state} {label}: {cell(case)}", flush=True)
                    rows.append((study, state, label, case))
        finally:
            for cache in caches.values():
                shutil.rmtree(cache, ignore_errors=True)
    return rows


def table(rows, codes: dict, started: str, loads: tuple) -> str:
    head = (f"Written by `python benchmarks/studies_cold_warm.py`; do not edit by hand. Measured {started} on "
            f"{platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}, a machine shared "
            f"with other work: load average (1, 5, 15 min) {loads[0]} at the start, {loads[1]} at the end.\n\n"
            "Wall seconds of the command in a new process, start to exit, and its split (seconds; see the "
            "benchmark's docstring): *start* imports, *compile* numba compiling (cache misses), *orbits* "
            "multiple-shooting corrections into the dated model, *rest* truth, measurements, runs, tables and "
            "figures. *Cold*: an empty LIAISON_CACHE_DIR; *warm*: the same folder right after. Code: "
            + "; ".join(f"*{label}* `{path}`" for label, path in codes.items()) + ".\n\n")
    lines = ["| study | cache | " + " | ".join(codes) + " |", "|---|---|" + "---|" * len(codes)]
    for study in dict.fromkeys(r[0] for r in rows):
        for state in ("cold", "warm"):
            cells = {label: cell(case) for s, st, label, case in rows if s == study and st == state}
            command = "liaison " + " ".join(STUDIES[study])
            lines.append(f"| `{command}` | {state} | " + " | ".join(cells.get(label, "-") for label in codes) + " |")
    return head + "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--code", action="append", default=[], help="LABEL=PATH of a folder holding liaison_cli")
    parser.add_argument("--study", action="append", choices=sorted(STUDIES), default=[])
    parser.add_argument("--output", type=Path, default=ROOT / "results" / "reference" / "studies_cold_warm.md")
    args = parser.parse_args()
    codes = dict(item.split("=", 1) for item in args.code) or {"this checkout": str(ROOT)}
    codes = {label: Path(path).resolve() for label, path in codes.items()}
    started = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load0 = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    rows = measure(codes, args.study or ["study004", "study003"])
    text = table(rows, codes, started, (load0, ", ".join(f"{x:.1f}" for x in os.getloadavg())))
    print(text)
    args.output.write_text(text)


if __name__ == "__main__":
    main()
