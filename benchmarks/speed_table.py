"""Issue 13's speed figures in one table, this tree beside an earlier commit, measured interleaved in one session.

    python -m benchmarks.speed_table [--before REV] [--repeats 3] [--skip-cold]

Rows (issue 13's targets beside them):
- `liaison run scenarios/smoke.yaml`: process start to exit (the first printed result comes just before the
  exit), compiled code cached.
- `liaison table3` (60 ten-day runs, `--jobs 2`), compiled code cached.
- `liaison run scenarios/eml2_lunar.yaml` with an empty compiled-code cache (the first-ever run).
- One 10-day eml2_lunar EKF run on one core after compilation (median of 40 runs in a fresh process, per tree
  and repetition), and the plain reference implementation (benchmarks/reference.py) on the same inputs: the
  ratio of the reference to this tree's best median.
- The whole work unit of one such run (`execute_run`: its draws, the filter and everything it records) and,
  on the same runs, the filter call alone (median of 40 each, in a fresh process per tree and repetition).

With `--before REV` (default: none) the same rows are measured on that commit's source tree (extracted with
`git archive` into a temporary folder and run from there), each repetition right after this tree's, so the
machine's drift (up to 1.5x within a session here) hits both alike. Every figure is the best of the
repetitions, with the range beside it.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _tree_env(tree: Path, **extra) -> dict:
    return {**os.environ, "PYTHONPATH": str(tree), **extra}


def _time_cli(tree: Path, args: list[str], env: dict) -> float:
    """Wall seconds of `python -m liaison_cli ARGS` run from `tree` (so that tree's package is imported)."""
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "liaison_cli", *args], cwd=tree, env=env,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"{tree}: liaison {' '.join(args)} failed: {proc.stderr.strip()}")
    return wall


def _per_run(tree: Path, reference_runs: int) -> dict:
    """benchmarks.engine_vs_reference.measure in a fresh process of `tree` (its own code and compiled cache)."""
    code = ("import json\nfrom benchmarks.engine_vs_reference import measure\n"
            f"print(json.dumps(measure(engine_runs=40, reference_runs={reference_runs}, verbose=False)))")
    out = subprocess.run([sys.executable, "-c", code], cwd=tree, env=_tree_env(tree), capture_output=True,
                         text=True)
    if out.returncode != 0:
        raise SystemExit(f"{tree}: engine_vs_reference failed: {out.stderr.strip()}")
    return json.loads(out.stdout.strip().splitlines()[-1])


# The whole work unit of a run (campaign.engine.worker.execute_run: the draws, the filter, everything a run records)
# and the filter call alone, on the same run indices, median of 40 each after one untimed call; only functions
# every measured tree has, so an earlier commit is timed by the same code.
_WHOLE_RUN = """
import json, time
import numpy as np
from liaison_cli.campaign.engine.worker import RunTask, draw_run_inputs, execute_run
from liaison_cli.estimation.estimators import estimate
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.setup import prepare_problem
problem = prepare_problem(load_scenario("scenarios/eml2_lunar.yaml")[0])
execute_run(problem, RunTask(0))
whole, filter_only = [], []
for run in range(40):
    t0 = time.perf_counter()
    execute_run(problem, RunTask(run))
    whole.append(time.perf_counter() - t0)
    inputs = draw_run_inputs(problem, run)
    t0 = time.perf_counter()
    estimate(problem.scenario.estimator, problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)
    filter_only.append(time.perf_counter() - t0)
print(json.dumps({"whole_s": float(np.median(whole)), "filter_s": float(np.median(filter_only))}))
"""


def _whole_run(tree: Path) -> dict:
    out = subprocess.run([sys.executable, "-c", _WHOLE_RUN], cwd=tree, env=_tree_env(tree), capture_output=True,
                         text=True)
    if out.returncode != 0:
        raise SystemExit(f"{tree}: the whole-run timing failed: {out.stderr.strip()}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def _extract(rev: str) -> Path:
    folder = Path(tempfile.mkdtemp(prefix=f"liaison-{rev[:10]}-"))
    archive = subprocess.run(["git", "archive", rev], cwd=ROOT, capture_output=True, check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    return folder


def _cell(values: list[float], unit: str) -> str:
    if not values:
        return ""
    best = min(values)
    spread = f" ({min(values):.2f}-{max(values):.2f})" if len(values) > 1 else ""
    return f"{best:.2f} {unit}{spread}"


def measure_rows(trees: dict, repeats: int, cold: bool) -> list[tuple[str, dict, str, str]]:
    """(label, {tree name: [values]}, unit, target) per row; trees interleaved within each repetition."""
    out = Path(tempfile.mkdtemp(prefix="liaison-speed-"))
    smoke, table3, first = ({name: [] for name in trees} for _ in range(3))
    for name, tree in trees.items():  # fill each tree's compiled-code cache
        _time_cli(tree, ["run", "scenarios/smoke.yaml", "--quiet", "--output", str(out / f"warm-{name}")],
                  _tree_env(tree))
        _time_cli(tree, ["table3", "--quiet", "--output", str(out / f"warm-t3-{name}")], _tree_env(tree))
    for repeat in range(repeats):
        for name, tree in trees.items():
            smoke[name].append(_time_cli(tree, ["run", "scenarios/smoke.yaml", "--quiet", "--overwrite", "--output",
                                                str(out / f"smoke-{name}")], _tree_env(tree)))
            table3[name].append(_time_cli(tree, ["table3", "--quiet", "--overwrite", "--output",
                                                 str(out / f"t3-{name}")], _tree_env(tree)))
            if cold:
                cache = out / f"cold-cache-{name}-{repeat}"
                first[name].append(_time_cli(tree, ["run", "scenarios/eml2_lunar.yaml", "--quiet", "--output",
                                                    str(out / f"cold-{name}-{repeat}")],
                                             _tree_env(tree, LIAISON_CACHE_DIR=str(cache))))
    engine = {name: [] for name in trees}
    whole, filter_call = ({name: [] for name in trees} for _ in range(2))
    for _ in range(repeats):  # the median of 40 runs, in a fresh process per tree and repetition
        for name, tree in trees.items():
            engine[name].append(1e3 * _per_run(tree, reference_runs=0)["engine_s"])
            timed = _whole_run(tree)
            whole[name].append(1e3 * timed["whole_s"])
            filter_call[name].append(1e3 * timed["filter_s"])
    reference = {"now": [1e3 * _per_run(ROOT, reference_runs=1)["reference_s"]]}
    ratio = reference["now"][0] / min(engine["now"])
    rows = [("liaison run scenarios/smoke.yaml, cached", smoke, "s", "<= 1.5 s"),
            ("liaison table3, 60 runs x 10 d, --jobs 2, cached", table3, "s", "<= 4 s")]
    if cold:
        rows.append(("liaison run scenarios/eml2_lunar.yaml, empty cache", first, "s", "<= 15 s"))
    rows.append(("one 10-day eml2_lunar EKF run, one core", engine, "ms", "<= 15 ms"))
    rows.append(("its whole work unit (execute_run: draws, filter, records), one core", whole, "ms", ""))
    rows.append(("... of which the filter call (estimate)", filter_call, "ms", ""))
    rows.append(("the same run, plain reference (this tree's process)", reference, "ms", f"ratio {ratio:.0f}x"))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", help="an earlier commit to measure beside this tree (e.g. 3429f64)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--skip-cold", action="store_true", help="leave out the empty-cache compilation row")
    args = parser.parse_args()
    trees = {"now": ROOT}
    if args.before:
        trees = {"before": _extract(args.before), "now": ROOT}
    rows = measure_rows(trees, args.repeats, not args.skip_cold)
    print(f"machine: {os.cpu_count()} cores; python {sys.version.split()[0]}; best of {args.repeats} (range)")
    header = f"| what | {'before (' + args.before + ') | ' if args.before else ''}now | target / note |"
    print(header)
    print("|---|" + ("---|" if args.before else "") + "---|---|")
    for label, values, unit, target in rows:
        before = f" {_cell(values.get('before', []), unit)} |" if args.before else ""
        print(f"| {label} |{before} {_cell(values.get('now', []), unit)} | {target} |")


if __name__ == "__main__":
    main()
