"""Wall time and peak memory of whole campaigns, as a user runs them (new processes, `--jobs 2`).

    python -m benchmarks.campaign_timing [--skip-cold]

Times `liaison table3` (6 cases x 10 runs of 10 days) and the default `liaison sweep --sigma 50:700`
(3 formations x 14 sigma x 10 runs = 420 runs). Each is run once with an empty compiled-code cache (the
first-ever run: numba compiles the engine) and then with the cache that run left behind (every later
run). Peak memory is the largest sum of resident set sizes over the process tree (parent plus worker
processes), sampled every 20 ms from /proc (Linux).
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PAGE_KB = os.sysconf("SC_PAGE_SIZE") // 1024


def _tree_rss_kb(root: int) -> int:
    children: dict[int, list[int]] = {}
    rss: dict[int, int] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as handle:
                fields = handle.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        pid, ppid = int(entry), int(fields[1])
        children.setdefault(ppid, []).append(pid)
        rss[pid] = int(fields[21]) * PAGE_KB
    total, stack = 0, [root]
    while stack:
        pid = stack.pop()
        total += rss.get(pid, 0)
        stack += children.get(pid, [])
    return total


def timed(args: list[str], env: dict) -> tuple[float, float]:
    """(wall seconds, peak tree RSS in MB) of one CLI invocation."""
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "liaison_cli", *args], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    peak = 0
    while proc.poll() is None:
        peak = max(peak, _tree_rss_kb(proc.pid))
        time.sleep(0.02)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"liaison {' '.join(args)} failed: {proc.stderr.read()}")
    return wall, peak / 1024


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-cold", action="store_true", help="only the warm-cache timings")
    parser.add_argument("--repeats", type=int, default=2, help="warm repetitions (best is reported)")
    args = parser.parse_args()
    out = Path(tempfile.mkdtemp(prefix="liaison-bench-"))
    cache = out / "cache"
    env = {**os.environ, "LIAISON_CACHE_DIR": str(cache)}
    commands = {
        "table3 (60 runs x 10 d)": ["table3", "--quiet", "--overwrite", "--output", str(out / "t3")],
        "sweep --sigma 50:700 (420 runs x 10 d)": ["sweep", "--sigma", "50:700", "--quiet", "--overwrite",
                                                   "--output", str(out / "sweep")],
    }
    print(f"machine: {os.cpu_count()} cores; python {sys.version.split()[0]}; jobs 2")
    if not args.skip_cold:
        wall, peak = timed(commands["table3 (60 runs x 10 d)"], env)
        print(f"{'table3, first-ever run (empty cache: numba compiles)':<62} {wall:7.2f} s wall  {peak:7.0f} MB peak")
    else:
        timed(commands["table3 (60 runs x 10 d)"], {**os.environ})  # make sure a cache exists
        env = dict(os.environ)
    for label, command in commands.items():
        results = [timed(command, env) for _ in range(args.repeats)]
        wall = min(r[0] for r in results)
        peak = max(r[1] for r in results)
        print(f"{label + ', cached compiled code':<62} {wall:7.2f} s wall  {peak:7.0f} MB peak")


if __name__ == "__main__":
    main()
