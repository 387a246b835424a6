"""Seconds per 004 study case on one core: one EKF run (one transmitter x one receiver pair, full arc) and
the LinCov pass along the truth, after compilation. The set-up (trajectories, orbit corrections,
measurements) is timed apart; as in `liaison study004`, a transmitter's pairs share its trajectories, so
the first pair pays for them.

    python -m benchmarks.study004_case_timing [--runs 5]
"""

import argparse
import time
from pathlib import Path

import numpy as np

from liaison_cli.campaign.studies.error_budget import error_budget
from liaison_cli.campaign.studies.study004 import pair_name, pair_scenario
from liaison_cli.campaign.engine.worker import RunTask, execute_run
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.setup import prepare_problem

SCENARIOS = ("scenarios/004/eml2_halo.yaml", "scenarios/004/dro.yaml", "scenarios/004/low_energy_transfer.yaml")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    print("| transmitter | pair | epochs | set-up s | EKF run s (median) | LinCov s |")
    print("|---|---|---|---|---|---|")
    for path in SCENARIOS:
        scenario, _ = load_scenario(path)
        shared: dict = {}
        for index, link in enumerate(scenario.links):
            t0 = time.perf_counter()
            problem = prepare_problem(pair_scenario(scenario, Path(path).stem, index), shared)
            setup_s = time.perf_counter() - t0
            execute_run(problem, RunTask(0))  # compiled code loaded (or compiled) here, not timed
            error_budget(problem)
            times = []
            for run in range(args.runs):
                t0 = time.perf_counter()
                execute_run(problem, RunTask(run))
                times.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            error_budget(problem)
            lincov_s = time.perf_counter() - t0
            print(f"| {Path(path).stem} | {pair_name(link)} | {len(problem.times_s)} | {setup_s:.1f} | "
                  f"{np.median(times):.3f} | {lincov_s:.3f} |")


if __name__ == "__main__":
    main()
