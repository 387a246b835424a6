"""First runs as a new user meets them: every `liaison new` template and each kind of shipped scenario, from an
empty cache and after `liaison warm-up`; writes results/reference/first_runs.md.

    python -m benchmarks.first_runs [--jobs 2] [--output results/reference/first_runs.md]

Each case is `liaison run SCENARIO --runs 2 --output TMP --quiet` in a new process, timed from start to exit:
- empty cache: a fresh LIAISON_CACHE_DIR of its own (numba compiles; dated orbits are corrected);
- after warm-up: `liaison warm-up --jobs N` once into a fresh cache (its own wall time is reported), then
  each case in a copy of that cache, so no case profits from another's run;
- second run: the same case again in its copy (everything cached): what remains is not compilation.
Whether the run compiled is read from its stderr (the first-compilation notice, cli.common.COMPILE_NOTICE).

The code measured is a snapshot of this working tree taken at the start (other edits meanwhile would change
the numeric core's hash and with it the cache folder). The machine is shared: the 1-minute load average is
recorded beside every run.
"""

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = ("crosslink-pair", "network", "nrho-batch", "dated-dsn", "tdoa-pair")
# One shipped scenario per kind (the smallest of each where there is a choice).
SHIPPED = {
    "CRTBP EKF": "eml2_lunar.yaml",
    "CRTBP EKF, angles": "mt_eml2_lunar_range_rate_los.yaml",
    "batch": "nrho_gateway_anchors.yaml",
    "dated (ephemeris) + DSN": "eph_eml1_eml2_dsn.yaml",
    "TDoA + FDoA (dated, initial batch)": "004/eml2_halo.yaml",
    "clock (one-way)": "clock_one_way_eml2_lunar.yaml",
    "smoke": "smoke.yaml",
}


def snapshot(work: Path) -> Path:
    """A copy of the package (and the scenarios/ link) as it is now."""
    tree = work / "tree"
    shutil.copytree(ROOT / "liaison_cli", tree / "liaison_cli", ignore=shutil.ignore_patterns("__pycache__"))
    (tree / "scenarios").symlink_to("liaison_cli/shipped_scenarios")
    return tree


def liaison(tree: Path, args: list, cache: Path, cwd: Path) -> tuple[float, str, str]:
    """(wall seconds, stdout, stderr) of `python -m liaison_cli ARGS` on the snapshot with this cache folder."""
    env = {**os.environ, "PYTHONPATH": str(tree), "LIAISON_CACHE_DIR": str(cache)}
    env.pop("NUMBA_CACHE_DIR", None)
    started = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "liaison_cli", *map(str, args)], cwd=cwd, env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - started
    if proc.returncode != 0:
        raise SystemExit(f"liaison {' '.join(map(str, args))} failed ({proc.returncode}): {proc.stderr.strip()}")
    return wall, proc.stdout, proc.stderr


def cases(tree: Path, work: Path) -> dict:
    """{label: scenario path}: the templates written by `liaison new`, then the shipped kinds."""
    out = {}
    for kind in TEMPLATES:
        path = work / f"{kind.replace('-', '_')}.yaml"
        liaison(tree, ["new", path, "--from", kind], work / "cache-new", work)
        out[f"template {kind}"] = path
    for label, name in SHIPPED.items():
        out[f"{label}: {name}"] = tree / "scenarios" / name
    return out


def compile_notice(tree: Path) -> str:
    """The snapshot's first-compilation notice (what its runs print when numba compiles)."""
    code = "from liaison_cli.cli.common import COMPILE_NOTICE; print(COMPILE_NOTICE)"
    return subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(tree)}, cwd=tree,
                          capture_output=True, text=True, check=True).stdout.strip()


def _run(tree, scenario, cache, work, tag, notice: str) -> dict:
    load = os.getloadavg()[0]
    wall, _, stderr = liaison(tree, ["run", scenario, "--runs", 2, "--quiet", "--output", work / f"out-{tag}"],
                           cache, work)
    return {"s": wall, "load": load, "compiled": notice in stderr}


def measure(tree: Path, work: Path, jobs: int) -> tuple[dict, dict]:
    """({case: {cold, warm, again}}, warm-up {s, load, lines: what it printed})."""
    notice = compile_notice(tree)
    rows = {}
    for i, (label, scenario) in enumerate(cases(tree, work).items()):
        cold = _run(tree, scenario, work / f"cold-{i}", work, f"cold-{i}", notice)
        rows[label] = {"scenario": scenario, "cold": cold}
        print(f"{label}: empty cache {rows[label]['cold']['s']:.1f} s", flush=True)
    warm = work / "warm"
    load = os.getloadavg()[0]
    wall, output, stderr = liaison(tree, ["warm-up", "--jobs", jobs], warm, work)
    if stderr.strip():  # the warm-up says everything on stdout; anything here is a fault to look at
        raise SystemExit(f"liaison warm-up wrote to stderr: {stderr.strip()}")
    warm_up = {"s": wall, "load": load, "lines": output.strip().splitlines()}
    print(f"warm-up: {wall:.1f} s: {warm_up['lines'][-1]}", flush=True)
    for i, (label, row) in enumerate(rows.items()):
        cache = work / f"warm-{i}"
        shutil.copytree(warm, cache)
        row["warm"] = _run(tree, row["scenario"], cache, work, f"warm-{i}", notice)
        row["again"] = _run(tree, row["scenario"], cache, work, f"again-{i}", notice)
        print(f"{label}: after warm-up {row['warm']['s']:.1f} s, again {row['again']['s']:.1f} s", flush=True)
    return rows, warm_up


def _machine() -> str:
    model = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                  if line.startswith("model name")), platform.processor() or platform.machine())
    return (f"{model}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, "
            f"python {platform.python_version()}")


def _tree_state() -> str:
    def git(*args):
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()

    dirty = " with uncommitted changes" if git("status", "--porcelain", "--untracked-files=no") else ""
    return f"commit {git('rev-parse', '--short', 'HEAD')}{dirty}"


def markdown(rows: dict, warm_up: dict, jobs: int, started: str, loads: tuple) -> str:
    def cell(m):
        return f"{m['s']:.1f} s, {'compiled' if m['compiled'] else 'cached'} (load {m['load']:.1f})"

    lines = [f"Written by `python -m benchmarks.first_runs --jobs {jobs}`; do not edit by hand. Measured {started} "
             f"on {_machine()}, a machine shared with other work: load average (1, 5, 15 min) {loads[0]} at the "
             f"start, {loads[1]} at the end. Code: a snapshot of the working tree ({_tree_state()}).",
             "",
             "Wall seconds of `liaison run SCENARIO --runs 2 --output TMP --quiet` in a new process, start to exit; "
             "*compiled*: the run printed the first-compilation notice (numba compiled), *cached*: it did not; "
             "then the 1-minute load average when the run started. *Empty cache*: a fresh LIAISON_CACHE_DIR per "
             "case. *After warm-up*: a copy of the cache one `liaison warm-up` filled. *Second run*: the same "
             "command again in that copy (compiled code and corrected dated orbits cached).",
             "",
             "| case | empty cache | after warm-up | second run |",
             "|---|---|---|---|"]
    for label, row in rows.items():
        lines.append(f"| {label} | {cell(row['cold'])} | {cell(row['warm'])} | {cell(row['again'])} |")
    total = sum(row["cold"]["s"] for row in rows.values())
    lines += ["", f"Empty cache, all {len(rows)} cases one after another: {total:.0f} s. "
              f"`liaison warm-up --jobs {jobs}` into an empty cache: {warm_up['s']:.1f} s wall, process start to "
              f"exit (load {warm_up['load']:.1f} at its start). It printed (its cache folder left out):", "",
              "```", warm_up["lines"][0].split("; cache ")[0], *warm_up["lines"][1:], "```", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs", type=int, default=2, help="the warm-up's --jobs")
    parser.add_argument("--output", type=Path, default=ROOT / "results" / "reference" / "first_runs.md")
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="liaison-first-runs-"))
    started = time.strftime("%Y-%m-%d %H:%M %Z")
    load_start = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    rows, warm_up = measure(snapshot(work), work, args.jobs)
    load_end = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    text = markdown(rows, warm_up, args.jobs, started, (load_start, load_end))
    args.output.write_text(text)
    print(text)
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
