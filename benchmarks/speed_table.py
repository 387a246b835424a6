"""Issue 13's speed figures in one table, measured in one session on this machine.

    python -m benchmarks.speed_table [--repeats 3] [--skip-cold]

Rows (targets from issue 13 beside them):
- `liaison run scenarios/smoke.yaml`: process start to exit (the first printed result is the last line),
  compiled code cached; best of `--repeats`.
- `liaison table3` (60 ten-day runs, `--jobs 2`), cached; best of `--repeats`.
- `liaison run scenarios/eml2_lunar.yaml` with an empty compiled-code cache (the first-ever run).
- Marginal time of one 10-day eml2_lunar run on one core (median of 40), and the plain reference
  implementation on the same inputs in the same process (benchmarks/reference.py), as a ratio.
"""

import argparse
import os
import sys
import tempfile
from pathlib import Path

from benchmarks.campaign_timing import timed
from benchmarks.engine_vs_reference import measure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--skip-cold", action="store_true", help="leave out the empty-cache compilation row")
    args = parser.parse_args()
    out = Path(tempfile.mkdtemp(prefix="liaison-speed-"))
    warm = dict(os.environ)
    timed(["run", "scenarios/smoke.yaml", "--quiet", "--output", str(out / "warmup")], warm)  # fill the cache
    rows = []

    def best(args_):
        return min(timed(args_ + ["--overwrite"], warm)[0] for _ in range(args.repeats))

    rows.append(("liaison run scenarios/smoke.yaml (cached)", best(["run", "scenarios/smoke.yaml", "--quiet",
                                                                    "--output", str(out / "smoke")]), "s", "<= 1.5 s"))
    rows.append(("liaison table3, 60 runs x 10 d, --jobs 2 (cached)",
                 best(["table3", "--quiet", "--output", str(out / "t3")]), "s", "<= 4 s"))
    if not args.skip_cold:
        cold = {**os.environ, "LIAISON_CACHE_DIR": str(out / "cold-cache")}
        wall, _ = timed(["run", "scenarios/eml2_lunar.yaml", "--quiet", "--output", str(out / "cold")], cold)
        rows.append(("liaison run scenarios/eml2_lunar.yaml, empty cache", wall, "s", "<= 15 s"))
    per_run = measure(engine_runs=40, reference_runs=1, verbose=False)
    rows.append(("one 10-day eml2_lunar run, engine, one core", 1e3 * per_run["engine_s"], "ms", "<= 15 ms"))
    rows.append(("the same run, plain reference (same process)", 1e3 * per_run["reference_s"], "ms",
                 f"ratio {per_run['reference_s'] / per_run['engine_s']:.0f}x"))
    print(f"machine: {os.cpu_count()} cores; python {sys.version.split()[0]}")
    print(f"| {'what':<52} | {'measured':>12} | {'target / note':<14} |")
    print(f"|{'-' * 54}|{'-' * 14}|{'-' * 16}|")
    for label, value, unit, target in rows:
        print(f"| {label:<52} | {value:>9.2f} {unit:<2} | {target:<14} |")


if __name__ == "__main__":
    main()
