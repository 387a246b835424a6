"""The default test suite and `liaison study004 --runs 2` under the host's OpenBLAS kernel and under Haswell,
Sandybridge and Nehalem, each from an empty compiled-code and orbit cache: the acceptance of "same answer on
every machine" (docs/reproducibility.md). Writes results/reference/kernel_suite.md.

    python -m benchmarks.kernel_suite [--kernels host,Haswell,Sandybridge,Nehalem] [--jobs 2]

Each kernel runs in a fresh LIAISON_CACHE_DIR (so nothing compiled or corrected under one kernel is read under
another) and the suite as the README runs it (`pytest`, every core); then study004 from a fresh folder. The
table: kernel, the suite's outcome line and wall seconds, study004's exit code and wall seconds, and the load
average before each kernel (a shared machine stretches the seconds; the outcomes are what this checks).
"""

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "kernel_suite.md"


def _environment(kernel: str, cache: str) -> dict:
    env = {**os.environ, "LIAISON_CACHE_DIR": cache}
    env.pop("OPENBLAS_CORETYPE", None)
    if kernel != "host":
        env["OPENBLAS_CORETYPE"] = kernel
    return env


def _timed(command: list[str], env: dict, cwd: Path) -> tuple[int, float, str]:
    start = time.perf_counter()
    done = subprocess.run(command, env=env, cwd=cwd, capture_output=True, text=True)
    lines = [line for line in done.stdout.splitlines() if line.strip()]
    failed = [line.split(" - ")[0].removeprefix("FAILED ").strip() for line in lines if line.startswith("FAILED ")]
    outcome = lines[-1] if lines else done.stderr.strip()[-200:]
    return done.returncode, time.perf_counter() - start, outcome + (f" (failed: {', '.join(failed)})" if failed else "")


def one_kernel(kernel: str, jobs: int) -> str:
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as work:
        env = _environment(kernel, cache)
        suite_rc, suite_s, suite_line = _timed([sys.executable, "-m", "pytest", "-q", "-rf", "-n", str(jobs),
                                                "-p", "no:cacheprovider"], env, REPO)
        study_rc, study_s, _ = _timed([sys.executable, "-m", "liaison_cli", "study004", "--runs", "2", "--jobs",
                                       str(jobs), "--output", str(Path(work) / "s004")], env, REPO)
    print(f"{kernel}: suite {suite_line} ({suite_s:.0f} s); study004 exit {study_rc} ({study_s:.0f} s)", flush=True)
    return (f"| {kernel} | {load:.1f} | {suite_line.strip('= ')} | {suite_s:.0f} | {'passed' if suite_rc == 0 else 'FAILED'} "
            f"| {study_rc} | {study_s:.0f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kernels", default="host,Haswell,Sandybridge,Nehalem")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args()
    rows = [one_kernel(kernel, args.jobs) for kernel in args.kernels.split(",")]
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else ""
    header = (f"Written by `python -m benchmarks.kernel_suite --kernels {args.kernels} --jobs {args.jobs}` on {cpu} "
              f"({os.cpu_count()} cores; the host's own kernel: OpenBLAS's choice for this CPU). Each kernel from an "
              "empty compiled-code and orbit cache.")
    table = ["| kernel | load before | suite | suite s | suite | study004 --runs 2 exit | study004 s |",
             "|---|---|---|---|---|---|---|", *rows]
    OUTPUT.write_text(header + "\n\n" + "\n".join(table) + "\n")
    print(OUTPUT.read_text())


if __name__ == "__main__":
    main()
