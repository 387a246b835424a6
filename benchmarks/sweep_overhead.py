"""Where the time of the Fig. 15 sweep goes, and its ratio to the ideal (issue 37, item 2).

    python benchmarks/sweep_overhead.py [--runs 10] [--jobs 2] [--repeat 1]

Run it with PYTHONPATH=<another checkout> to measure that code instead (before/after, side by side).
Stages, in this process (the sweep's own code, wrapped with timers):
  start    a fresh interpreter importing what `liaison sweep` imports (subprocess, wall)
  truth    the problems of every grid point (prepare_problem with the shared truth cache)
  warm-up  the parent's one run that loads the compiled core before the workers start (warm_up_here, its result
           dropped; since issue 37's fork workers: run_first_here, its result kept)
  fan-out  the pool's work, wall, from the first batch submitted to the last result in the manifest (since the
           fork workers the problems after the first are prepared inside it: truth then overlaps fan-out, and
           `other` comes out negative by that overlap)
  tables   reading the manifest back and writing the Parquet tables
  compute  the sum of every run's compute, measured serially in this process on a sample of each point
The ideal is compute / jobs + start; `cli` is the whole command, a subprocess, wall. On a shared machine the
cores actually available are measured too (effective_cores) and the ideal given on them as well.
Needs a warm compiled cache (run any sweep once first). Numbers depend on the load: `uptime` is printed.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FORMATIONS = ("eml2_lunar", "eml1_lunar", "eml1_eml2")


def _load() -> float:
    return os.getloadavg()[0]


def time_start() -> float:
    """A fresh process importing the sweep command's modules (what every `liaison sweep` pays once)."""
    code = "import liaison_cli.cli, liaison_cli.cli.sweep, liaison_cli.campaign.sweep.run, liaison_cli.scenario.setup"
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True)
    return time.perf_counter() - t0


def time_cli(runs: int, jobs: int) -> tuple[float, float]:
    """(wall, CPU) seconds of the whole command; CPU: user + system of its process tree (the workers are its
    children and are waited for), which the load of a shared machine does not inflate as it does the wall."""
    import resource

    def cpu() -> float:
        usage = resource.getrusage(resource.RUSAGE_CHILDREN)
        return usage.ru_utime + usage.ru_stime

    with tempfile.TemporaryDirectory() as folder:
        t0, c0 = time.perf_counter(), cpu()
        subprocess.run([sys.executable, "-c", "from liaison_cli.cli import main; main()", "sweep", "--sigma",
                        "50:700", "--runs", str(runs), "--jobs", str(jobs), "--quiet", "--output",
                        f"{folder}/s"], check=True, stdout=subprocess.DEVNULL)
        return time.perf_counter() - t0, cpu() - c0


def _plan(runs: int):
    from liaison_cli.campaign.sweep.grid import parse_range
    from liaison_cli.campaign.sweep.plan import SIGMA_KEY, plan_sweep
    from liaison_cli.scenario.loading import load_scenario
    from liaison_cli.scenario.shipped import scenario_folder

    bases = [(*load_scenario(path), str(path)) for path in
             (scenario_folder(None) / f"{formation}.yaml" for formation in FORMATIONS)]
    return plan_sweep(bases, [(SIGMA_KEY, parse_range("50:700", "--sigma"))], runs, "fig15")


def _timed(module, name: str, stages: dict, key: str, generator: bool = False):
    """Wrap module.name so its time (a generator's: until exhausted) adds to stages[key] (absent: nothing)."""
    if not hasattr(module, name):  # the code measured is older or newer than this benchmark
        return
    original = getattr(module, name)

    def plain(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            stages[key] = stages.get(key, 0.0) + time.perf_counter() - t0

    def lazy(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            yield from original(*args, **kwargs)
        finally:
            stages[key] = stages.get(key, 0.0) + time.perf_counter() - t0

    setattr(module, name, lazy if generator else plain)


def time_stages(runs: int, jobs: int) -> dict:
    """run_sweep in this process, its stages timed by wrapping the functions it calls."""
    import liaison_cli.campaign.sweep.run as sweep

    stages: dict = {}
    _timed(sweep, "prepare_problem", stages, "truth")
    _timed(sweep, "warm_up_here", stages, "warm-up")
    _timed(sweep, "run_first_here", stages, "warm-up")
    _timed(sweep, "map_batches", stages, "fan-out", generator=True)
    _timed(sweep, "read_manifest", stages, "tables")
    _timed(sweep, "build_runs_table", stages, "tables")
    _timed(sweep, "build_curve_table", stages, "tables")
    _timed(sweep, "write_sweep_tables", stages, "tables")
    plan = _plan(runs)
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        sweep.run_sweep(plan, Path(folder) / "s", jobs=jobs, progress=False)
        stages["run_sweep"] = time.perf_counter() - t0
    return stages


def time_compute(runs: int, sample: int = 3) -> float:
    """Sum of every run's compute: `sample` runs of each grid point, serially here, scaled to `runs`."""
    from liaison_cli.campaign.sweep.worker import execute_sweep_batch
    from liaison_cli.scenario.setup import prepare_problem

    plan = _plan(runs)
    cache: dict = {}
    problems = [prepare_problem(point.scenario, cache) for point in plan.points]
    execute_sweep_batch(problems[0], plan.tasks[:1])  # loads the compiled core: not a run's cost
    total = 0.0
    for index, problem in enumerate(problems):
        tasks = [task for task in plan.tasks if task.point == index][:sample]
        t0 = time.perf_counter()
        execute_sweep_batch(problem, tasks)
        total += (time.perf_counter() - t0) / len(tasks) * runs
    return total


def effective_cores(jobs: int) -> float:
    """The cores this machine gives us now: `jobs` copies of a CPU loop at once against one alone (2 on a quiet
    2-core machine, about 1 when others keep one core busy). The ideal is then also given on these cores."""
    loop = [sys.executable, "-c", "sum(i * i for i in range(12_000_000))"]

    def wall(copies: int) -> float:
        t0 = time.perf_counter()
        for process in [subprocess.Popen(loop) for _ in range(copies)]:
            process.wait()
        return time.perf_counter() - t0

    alone = wall(1)
    return min(jobs, jobs * alone / wall(jobs))


def measure(runs: int, jobs: int) -> dict:
    """One of everything: the start, the command (wall and CPU), its stages in this process, the compute."""
    load0 = _load()
    start = time_start()
    cli, cli_cpu = time_cli(runs, jobs)
    stages = time_stages(runs, jobs)
    compute = time_compute(runs)
    cores = effective_cores(jobs)
    in_sweep = stages.pop("run_sweep")
    return {"load": load0, "load_end": _load(), "start": start, "cli": cli, "cli_cpu": cli_cpu, "stages": stages,
            "run_sweep": in_sweep, "other": in_sweep - sum(stages.values()), "compute": compute, "cores": cores,
            "ideal": compute / jobs + start, "ideal_here": compute / cores + start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--json", action="store_true", help="one JSON line per repeat (benchmarks/sweep_ab.py)")
    args = parser.parse_args()
    import json

    import liaison_cli

    if not args.json:
        print(f"code: {Path(liaison_cli.__file__).parent}; runs {args.runs} x 42 points, jobs {args.jobs}")
    for _ in range(args.repeat):
        m = measure(args.runs, args.jobs)
        if args.json:
            print(json.dumps(m), flush=True)
            continue
        parts = "  ".join(f"{k} {v:.2f}" for k, v in m["stages"].items())
        print(f"load {m['load']:.2f}->{m['load_end']:.2f} | start {m['start']:.2f}  {parts}  other {m['other']:.2f}  "
              f"(run_sweep {m['run_sweep']:.2f}) | compute {m['compute']:.2f} | ideal {m['ideal']:.2f}  cli "
              f"{m['cli']:.2f} (CPU {m['cli_cpu']:.2f})  ratio {m['cli'] / m['ideal']:.3f} | effective cores "
              f"{m['cores']:.2f}: ideal {m['ideal_here']:.2f}  ratio {m['cli'] / m['ideal_here']:.3f}")


if __name__ == "__main__":
    main()
