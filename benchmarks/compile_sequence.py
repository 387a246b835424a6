"""What a new user pays the compiler, in the order a user meets it: one cache folder, filled as the commands run.

    python -m benchmarks.compile_sequence [--before REV] [--tree PATH | --commit REV] [--output FILE]

From an empty LIAISON_CACHE_DIR: the first-ever `liaison run` of eml2_lunar, then one scenario of each other
kind (angles, one-way clocks, the batch, the dated model, TDoA on the dated model, the initial batch), then
`liaison errors` on eml2_lunar, each `--runs 2 --quiet` in a new process, timed start to exit; then
`liaison warm-up` into a second empty cache. Every case after the first pays only for what the earlier ones
did not compile: the cost of a new kind of scenario. Each case is run a second time in the same cache (all
cached) so the compile share is the difference.

`--commit REV` measures a commit of this repository (checked out into a temporary folder) instead of this
working tree, `--tree PATH` another checkout; `--before REV` measures that commit first, then this tree, in one
session on the same machine, and writes both side by side. The load average is recorded beside every case.
"""

import argparse
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from benchmarks import first_runs

ROOT = Path(__file__).resolve().parents[1]
# (label, liaison arguments); {scenarios} is the measured tree's scenarios/ folder, {work} the scratch folder.
SEQUENCE = (
    ("run eml2_lunar (first ever)", ["run", "{scenarios}/eml2_lunar.yaml"]),
    ("run LOS angles", ["run", "{scenarios}/mt_eml2_lunar_range_rate_los.yaml"]),
    ("run one-way clocks", ["run", "{scenarios}/clock_one_way_eml2_lunar.yaml"]),
    ("run batch", ["run", "{scenarios}/nrho_gateway_anchors.yaml"]),
    ("run dated model + DSN", ["run", "{scenarios}/eph_eml1_eml2_dsn.yaml"]),
    ("run dated TDoA template", ["run", "{work}/tdoa_pair.yaml"]),
    ("run 004 initial batch", ["run", "{scenarios}/004/eml2_halo.yaml"]),
    ("errors eml2_lunar (LinCov)", ["errors", "{scenarios}/eml2_lunar.yaml"]),
)


def checkout(commit: str, work: Path) -> Path:
    tree = work / "tree"
    subprocess.run(["git", "worktree", "add", "--detach", "-f", str(tree), commit], cwd=ROOT, check=True,
                   capture_output=True)
    return tree


def liaison(tree: Path, args: list, cache: Path, cwd: Path) -> float:
    """Wall seconds of `python -m liaison_cli ARGS` on `tree` with this cache folder (benchmarks.first_runs')."""
    return first_runs.liaison(tree, args, cache, cwd)[0]


def measure(tree: Path, work: Path, warm_up: bool) -> list[dict]:
    cache = work / "cache"
    liaison(tree, ["new", work / "tdoa_pair.yaml", "--from", "tdoa-pair"], work / "cache-new", work)
    rows = []
    for i, (label, template) in enumerate(SEQUENCE):
        args = [a.format(scenarios=tree / "scenarios", work=work) for a in template]
        extra = ["--runs", 2, "--quiet"] if args[0] == "run" else ["--quiet"]
        out = ["--output", work / f"out-{i}", "--overwrite"]
        load = os.getloadavg()[0]
        first = liaison(tree, [*args, *extra, *out], cache, work)
        again = liaison(tree, [*args, *extra, *out], cache, work)
        rows.append({"label": label, "first": first, "again": again, "load": load})
        print(f"{label}: {first:.1f} s, again {again:.1f} s (load {load:.1f})", flush=True)
    if warm_up:
        load = os.getloadavg()[0]
        wall = liaison(tree, ["warm-up", "--jobs", 2], work / "cache-warm", work)
        rows.append({"label": "warm-up --jobs 2 (empty cache)", "first": wall, "again": float("nan"), "load": load})
        print(f"warm-up: {wall:.1f} s (load {load:.1f})", flush=True)
    return rows


def markdown(measured: dict, command: str, started: str) -> str:
    names = list(measured)
    head = " | ".join(f"{name}: first (s) | {name}: again (s)" for name in names)
    lines = [f"Written by `python -m benchmarks.compile_sequence{command}`; measured {started} on "
             f"{os.cpu_count()} cores. *First*: the command in a new process with what the cases above it left in "
             "the cache (the first case: an empty cache); *again*: the same command at once after it (all "
             "cached), so first minus again is what it compiled. Load: the 1-minute load average at its start.",
             "", f"| case | {head} | load |", "|---" * (2 + 2 * len(names)) + "|"]
    for i, row in enumerate(measured[names[0]]):
        cells = " | ".join(f"{measured[n][i]['first']:.1f} | {measured[n][i]['again']:.1f}" for n in names)
        loads = " / ".join(f"{measured[n][i]['load']:.1f}" for n in names)
        lines.append(f"| {row['label']} | {cells} | {loads} |")
    return "\n".join(lines).replace(" | nan |", " | - |") + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--tree", type=Path, help="another checkout to measure (default: this one)")
    where.add_argument("--commit", help="a commit of this repository to measure")
    parser.add_argument("--before", help="a commit measured first, beside this tree")
    parser.add_argument("--no-warm-up", action="store_true", help="skip the warm-up from an empty cache")
    parser.add_argument("--output", type=Path, help="write the Markdown table here too")
    args = parser.parse_args()
    started = time.strftime("%Y-%m-%d %H:%M %Z")
    plan = ([("before " + args.before, args.before, None)] if args.before else []) + [
        ("now" if not (args.commit or args.tree) else (args.commit or "tree"), args.commit, args.tree)]
    measured = {}
    for name, commit, tree_path in plan:
        work = Path(tempfile.mkdtemp(prefix="liaison-compile-sequence-"))
        tree = checkout(commit, work) if commit else (tree_path or ROOT).resolve()
        try:
            print(f"== {name}", flush=True)
            measured[name] = measure(tree, work, not args.no_warm_up)
        finally:
            if commit:
                subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, capture_output=True)
            shutil.rmtree(work, ignore_errors=True)
    command = "".join(f" --{k.replace('_', '-')} {v}" for k, v in (("before", args.before), ("commit", args.commit))
                      if v) + (" --no-warm-up" if args.no_warm_up else "")
    text = markdown(measured, command, started)
    print(text)
    if args.output:
        args.output.write_text(text)


if __name__ == "__main__":
    main()
