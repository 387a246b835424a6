"""Why one factor on the omitted lunar field's density cannot make a truncated field consistent, measured (the
ground of scenario.default_noise's rule for it): writes results/reference/lunar_noise_coupling.md.

`python -m benchmarks.lunar_noise_coupling [--runs 8] [--days 2]` flies benchmarks.lunar_field_truncation's
formation (the 9:2 NRHO relay and a 100 km polar orbiter, range + range-rate every 60 s, truth GRGM1200A at degree
100) with the filter's field at degree 0, 10, 20 and 50, and reports two things:

1. The omitted field's effect measured by propagation instead of by its correlation time: the user flown T
   seconds from points along day 1 under the truth's field and under the filter's, and the white acceleration
   density that would open the same separation, q = |dr(T)|^2 / T^3 (per axis: variance q T^3 / 3), for T of
   600 s to one orbit, against the omitted field's 2 a_rms^2 tau (scenario.default_noise.field_truncation_psd; the
   default's part before its rule took FIELD_PART_FACTOR of it).
2. The relay through the crosslink: the campaign's verdict per spacecraft with the user's PSD at that unscaled
   default (the floor plus 2 a_rms^2 tau) times a factor and the relay's PSD at its floor or at a fraction of the
   user's. The relay has no field error of
   its own at the NRHO's distance, yet with the user's PSD lowered towards what the propagation says, the relay's
   NEES leaves its band unless the relay carries noise too: the user's error is coloured, its white model leaks
   into the relay through the range.
"""

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from benchmarks.lunar_field_truncation import _verdict_cells, formation

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "lunar_noise_coupling.md"
DEGREES = (0, 10, 20, 50)
HORIZONS_S = (600.0, 1800.0, 3600.0, 7070.0)  # the last: about one 100 km orbit
USER_FACTORS = (1.0, 0.3, 0.1)
RELAY_SHARES = (None, 1e-5, 1e-4)  # None: the floor; else that share of the user's unscaled default


def _problem(degree: int, days: float, runs: int, psd=(None, None), truth_cache=None):
    from liaison_cli.scenario.loading import validate_scenario
    from liaison_cli.scenario.setup import prepare_problem

    mapping = formation(degree, days, runs)
    for spacecraft, q in zip(mapping["spacecraft"], psd):
        if q is not None:
            spacecraft["process_noise_psd_m2_s3"] = q
    return prepare_problem(validate_scenario(mapping, mapping["name"]), truth_cache)


def unscaled_default(problem, name: str) -> float:
    """The user's default as it was before the truncated field's rule (scenario.default_noise: FIELD_PART_FACTOR, the
    coupling share): the floor plus the omitted field's 2 a_rms^2 tau."""
    from liaison_cli.scenario.default_noise import FLOOR_PSD_M2_S3, field_truncation_psd

    column = 6 * problem.spacecraft.index(name)
    return FLOOR_PSD_M2_S3 + field_truncation_psd(problem.scenario, problem.dynamics,
                                                  problem.truth[:, column : column + 6], problem.times_s)


def propagation_psd(problem, name: str, horizon_s: float, starts: int = 12) -> float:
    """Mean over `starts` points along day 1 of |r_truth(T) - r_filter(T)|^2 / T^3 for the spacecraft `name`."""
    from liaison_cli.dynamics.constants import M_PER_LU, TU_S

    model = problem.dynamics
    filter_model = dataclasses.replace(model, params=model.filter_only_params)
    column = 6 * problem.spacecraft.index(name)
    interval_s = float(problem.times_s[1] - problem.times_s[0])
    values = []
    for start_s in np.linspace(0.0, 86400.0, starts, endpoint=False):
        state = problem.truth[int(round(start_s / interval_s)), column : column + 6]
        times_tu = np.linspace(0.0, horizon_s, 11) / TU_S
        separation_m = np.linalg.norm(model.truth_states(state, times_tu)[-1, :3]
                                      - filter_model.truth_states(state, times_tu)[-1, :3]) * M_PER_LU
        values.append(separation_m**2 / horizon_s**3)
    return float(np.mean(values))


def propagation_table(days: float, runs: int) -> list[str]:
    lines = ["| filter degree | the user's unscaled default q, m²/s³ | " + " | ".join(f"T = {t:.0f} s" for t in HORIZONS_S)
             + " |", "|---|---|" + "---|" * len(HORIZONS_S)]
    for degree in DEGREES:
        problem = _problem(degree, days, runs)
        default = unscaled_default(problem, "User")
        cells = [f"{q:.2g} ({q / default:.2g}×)" for q in (propagation_psd(problem, "User", t) for t in HORIZONS_S)]
        lines.append(f"| {degree} | {default:.2g} | " + " | ".join(cells) + " |")
    return lines


def coupling_table(days: float, runs: int) -> list[str]:
    from liaison_cli.campaign.engine.results import summary_table
    from liaison_cli.campaign.engine.runner import CampaignResult, iter_outcomes
    from liaison_cli.scenario.default_noise import FLOOR_PSD_M2_S3

    lines = ["| filter degree | user q × unscaled default | relay q | spacecraft | pos RMS after day 1, m | σ RMS, m | err/σ | "
             "own NEES in band | verdict |", "|---|---|---|---|---|---|---|---|---|"]
    truth_cache: dict = {}
    for degree in (10, 20):
        user_default = unscaled_default(_problem(degree, days, runs, truth_cache=truth_cache), "User")
        for factor in USER_FACTORS:
            for share in RELAY_SHARES:
                relay_q = FLOOR_PSD_M2_S3 if share is None else share * user_default
                problem = _problem(degree, days, runs, (relay_q, factor * user_default), truth_cache)
                summary = summary_table(CampaignResult(problem, tuple(iter_outcomes(problem, runs, jobs=2,
                                                                                    progress=False))))
                relay_label = "floor" if share is None else f"{share:g} × user's unscaled default"
                for name, group in summary.groupby("spacecraft", sort=False):
                    ok = group[group.status == "ok"]
                    cells = _verdict_cells(ok) if len(ok) else ("–",) * 5
                    lines.append(f"| {degree} | {factor:g} | {relay_label} | {name} | {' | '.join(cells)} |")
                print(lines[-2], lines[-1], sep="\n", flush=True)
    return lines


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=8)
    parser.add_argument("--days", type=float, default=2.0)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    parts = [f"Written by `python -m benchmarks.lunar_noise_coupling --runs {args.runs} --days {args.days:g}`; do "
             "not edit by hand. NRHO relay + 100 km polar orbiter, range + range-rate every 60 s (2.21 m, 11 mm/s), "
             "truth GRGM1200A at degree 100.", "",
             "The user's omitted field as a white density, by propagation (|Δr(T)|² / T³, mean over 12 starts along "
             "day 1; in brackets, against the user's unscaled default: its floor, 3e-18, plus the omitted field's 2 a² τ, "
             "the default's field part before it took 0.3 of that):", "", *propagation_table(args.days, args.runs), "",
             f"The crosslink: {args.runs} runs of {args.days:g} d per row, statistics after day 1:", "",
             *coupling_table(args.days, args.runs), "",
             f"Total {time.perf_counter() - started:.0f} s wall time (--jobs 2)."]
    OUTPUT.write_text("\n".join(parts) + "\n")
    print(OUTPUT.read_text())


if __name__ == "__main__":
    main()
