"""The Fig. 15 sweep's overhead, two versions of the code side by side (issue 37, item 2).

    python benchmarks/sweep_ab.py --code before=/path/a --code after=/path/b [--repeat 3] [--runs 10]
                                  [--output results/reference/sweep_overhead.md]

Each `--code LABEL=PATH` is a folder holding a `liaison_cli` package (a snapshot of a checkout). Each has its own
compiled cache (a fresh LIAISON_CACHE_DIR, warmed by one untimed sweep first); then benchmarks/sweep_overhead.py
runs under each in turn, alternating, `--repeat` times, so the load of a shared machine falls on both alike. Per
code: the command's wall (best and median), its CPU (user + system of its process tree: the load does not
inflate it), the ideal (the runs' compute / jobs + one process start) and the ratio, and where the time went in
an in-process run_sweep (see sweep_overhead.py). Writes the markdown table to `--output`.
"""

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
from datetime import datetime, timezone
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def _env(code: Path, cache: Path) -> dict:
    return {**os.environ, "PYTHONPATH": str(code), "LIAISON_CACHE_DIR": str(cache)}


# The working folder of every child: `python -c` and `-m` put it first on sys.path, before PYTHONPATH, so a
# checkout's own folder there would shadow the code under test.
NEUTRAL = tempfile.gettempdir()


def warm(code: Path, cache: Path, jobs: int) -> None:
    with tempfile.TemporaryDirectory() as folder:
        subprocess.run([sys.executable, "-m", "liaison_cli", "sweep", "--sigma", "50:700", "--runs", "1", "--jobs",
                        str(jobs), "--quiet", "--output", f"{folder}/s"], env=_env(code, cache), check=True,
                       cwd=NEUTRAL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def once(code: Path, cache: Path, runs: int, jobs: int) -> dict:
    done = subprocess.run([sys.executable, str(HERE / "sweep_overhead.py"), "--runs", str(runs), "--jobs", str(jobs),
                           "--json"], env=_env(code, cache), cwd=NEUTRAL, check=True, capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def row(label: str, ms: list[dict]) -> str:
    def best_median(key):
        values = [m[key] for m in ms]
        return f"{min(values):.2f} / {statistics.median(values):.2f}"

    ratios = [m["cli"] / m["ideal"] for m in ms]
    here = [m["cli"] / m["ideal_here"] for m in ms]
    stages = {k: statistics.median([m["stages"].get(k, 0.0) for m in ms]) for k in ms[0]["stages"]}
    stages["other"] = statistics.median([m["other"] for m in ms])
    split = ", ".join(f"{k} {v:.2f}" for k, v in stages.items())
    loads = ", ".join(f"{m['load']:.1f}" for m in ms)
    return (f"| {label} | {best_median('cli')} | {best_median('cli_cpu')} | {best_median('ideal')} | "
            f"{min(ratios):.2f} / {statistics.median(ratios):.2f} | {min(here):.2f} / {statistics.median(here):.2f} | "
            f"{best_median('start')} | "
            f"{statistics.median([m['run_sweep'] for m in ms]):.2f} ({split}) | {loads} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--code", action="append", required=True, help="LABEL=PATH of a folder holding liaison_cli")
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--output", type=Path, default=ROOT / "results" / "reference" / "sweep_overhead.md")
    args = parser.parse_args()
    codes = {label: Path(path).resolve() for label, path in (item.split("=", 1) for item in args.code)}
    caches = {label: Path(tempfile.mkdtemp(prefix=f"liaison-sweep-{label}-")) for label in codes}
    started = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load0 = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    results: dict = {label: [] for label in codes}
    try:
        for label, code in codes.items():
            warm(code, caches[label], args.jobs)
        for _ in range(args.repeat):
            for label, code in codes.items():
                results[label].append(once(code, caches[label], args.runs, args.jobs))
                m = results[label][-1]
                print(f"{label}: cli {m['cli']:.2f} s (CPU {m['cli_cpu']:.2f}), ideal {m['ideal']:.2f}, "
                      f"load {m['load']:.1f}", flush=True)
    finally:
        for cache in caches.values():
            shutil.rmtree(cache, ignore_errors=True)
    text = (f"Written by `python benchmarks/sweep_ab.py`; do not edit by hand. Measured {started} on "
            f"{platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}, a machine shared with "
            f"other work: load average (1, 5, 15 min) {load0} at the start, "
            f"{', '.join(f'{x:.1f}' for x in os.getloadavg())} at the end.\n\n"
            f"`liaison sweep --sigma 50:700 --runs {args.runs} --jobs {args.jobs}` (42 points x {args.runs} runs x 10 "
            f"days), warm compiled cache, {args.repeat} alternating repetitions per code; seconds, best / median. "
            "*CPU*: user + system of the command's process tree. *Ideal*: the runs' compute / jobs + one process "
            "start. *In-process run_sweep*: the median of its stages (see benchmarks/sweep_overhead.py; with forked "
            "workers the problems after the first are prepared inside the fan-out, so *other* is negative by that "
            "overlap). Code: " + "; ".join(f"*{label}* `{path}`" for label, path in codes.items()) + ".\n\n"
            "*On the cores available*: the ideal on the cores a CPU loop got at that moment (sweep_overhead.py's "
            "effective_cores: 2 on a quiet machine).\n\n"
            "| code | command wall | command CPU | ideal | wall / ideal | wall / ideal on the cores available | start "
            "| in-process run_sweep (stages) | load at each |\n|---|---|---|---|---|---|---|---|---|\n"
            + "\n".join(row(label, ms) for label, ms in results.items()) + "\n")
    print(text)
    args.output.write_text(text)


if __name__ == "__main__":
    main()
