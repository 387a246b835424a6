"""Peak memory of a large `liaison run`: results stream to disk, so memory must not grow with the run count.

Runs `liaison run SCENARIO --runs N` for each N given, samples the resident set of the whole process tree
(the main process and its workers, read from /proc every 0.2 s) and prints, per N: wall seconds, peak RSS
of the main process, peak RSS summed over the tree, and the size of the results folder.

    python -m benchmarks.memory_many_runs                       # smoke.yaml at 1,000 and 10,000 runs
    python -m benchmarks.memory_many_runs --runs 100,1000,10000 --scenario scenarios/smoke.yaml
"""

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.campaign_timing import PAGE_KB, _tree_rss_kb


def _rss_mb(pid: int) -> float:
    try:
        return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * PAGE_KB / 1024
    except (OSError, IndexError, ValueError):
        return 0.0


def measure(scenario: str, runs: int, jobs: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "result"
        command = [sys.executable, "-m", "liaison_cli", "run", scenario, "--runs", str(runs), "--jobs", str(jobs),
                   "--output", str(out), "--quiet"]
        start = time.perf_counter()
        process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        peak_main = peak_tree = 0.0
        while process.poll() is None:
            peak_main = max(peak_main, _rss_mb(process.pid))
            peak_tree = max(peak_tree, _tree_rss_kb(process.pid) / 1024)
            time.sleep(0.2)
        wall = time.perf_counter() - start
        if process.returncode != 0:
            raise SystemExit(f"liaison run failed ({process.returncode}): {process.stderr.read().decode()[-500:]}")
        size_mb = sum(f.stat().st_size for f in out.iterdir()) / 2**20
    return {"runs": runs, "wall_s": wall, "peak_main_mb": peak_main, "peak_tree_mb": peak_tree,
            "results_mb": size_mb}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/smoke.yaml")
    parser.add_argument("--runs", default="1000,10000", help="comma-separated run counts")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    print(f"{args.scenario}, --jobs {args.jobs}; RSS sampled every 0.2 s")
    print(f"{'runs':>7} {'wall s':>8} {'peak main MB':>13} {'peak tree MB':>13} {'results MB':>11}")
    for runs in (int(r) for r in args.runs.split(",")):
        row = measure(args.scenario, runs, args.jobs)
        print(f"{row['runs']:>7} {row['wall_s']:>8.1f} {row['peak_main_mb']:>13.0f} {row['peak_tree_mb']:>13.0f} "
              f"{row['results_mb']:>11.1f}")


if __name__ == "__main__":
    main()
