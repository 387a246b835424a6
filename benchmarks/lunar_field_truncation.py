"""What the Moon's field changes for an NRHO relay and a low lunar orbiter: writes
results/reference/lunar_field_truncation.md (docs/lunar-field.md includes it).

`python -m benchmarks.lunar_field_truncation [--runs 8] [--days 2]` flies the `lunar-relay` template's formation
(the 9:2 southern NRHO relay and a 100 km polar orbiter; two-way range and range-rate every 60 s at CAPSTONE's
worst published noise, 2.21 m and 11 mm/s) under a degree-100 GRGM1200A truth, with the filter's field at
degree 0 (a point-mass Moon), 10, 20, 50 and 100, every filter setting left to its default. Per filter degree
and spacecraft, over the epochs after day 1: the position error RMS and the filter's sigma RMS, err/sigma with
its 95 % interval, the spacecraft's own-NEES share in its band, the verdict, and the process noise the default
chose (scenario.default_noise: its floor plus its "lunar field beyond degree N" part). Then, per truncated
filter, `liaison tune`'s rule on its default ladder (campaign.studies.tuning.tune_case, the same runs): the
SNC it chooses and the position RMS and err/sigma there.
"""

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "lunar_field_truncation.md"
TRUTH_DEGREE = 100
FILTER_DEGREES = (0, 10, 20, 50, 100)


def formation(filter_degree: int, days: float, runs: int) -> dict:
    return {"name": f"relay_filter_{filter_degree}", "duration_days": days,
            "spacecraft": [{"name": "Relay", "orbit": "nrho_gateway"},
                           {"name": "User", "orbit": "lunar_keplerian",
                            "elements": {"altitude_km": 100.0, "e": 0.0, "i_deg": 90.0, "raan_deg": 30.0}}],
            "links": [{"receiver": "Relay", "transponder": "User", "observables": ["range", "range_rate"]}],
            "measurement": {"interval_s": 60}, "noise": {"sigma_m": 2.21, "range_rate_sigma_m_s": 0.011},
            "moon_gravity": {"degree": TRUTH_DEGREE, "filter_degree": filter_degree},
            "monte_carlo": {"runs": runs, "seed": 1}}


def _verdict_cells(rows) -> tuple[str, str, str, str, str]:
    """(pos RMS, sigma RMS, err/sigma ± half-width, own-NEES in band, verdict) of one spacecraft's finished runs."""
    from liaison_cli.analysis.consistency import campaign_verdict

    verdict = campaign_verdict(rows)
    return (f"{np.sqrt(np.mean(rows.rms_position_settled_m ** 2)):.3g}",
            f"{np.sqrt(np.mean(rows.sigma_position_settled_m ** 2)):.3g}",
            f"{verdict['position_error_to_sigma_settled']:.2f} ± {verdict['position_error_to_sigma_halfwidth']:.2f}",
            f"{100 * verdict['frac_nees_spacecraft_in_band_settled']:.0f} %",
            "consistent" if verdict["consistent_settled"] else
            ("pessimistic" if verdict["position_error_to_sigma_settled"] < 1 else "optimistic"))


def defaults_table(days: float, runs: int, truth_cache: dict) -> tuple[list[str], dict]:
    from liaison_cli.campaign.engine.results import summary_table
    from liaison_cli.campaign.engine.runner import CampaignResult, iter_outcomes
    from liaison_cli.scenario.loading import validate_scenario
    from liaison_cli.scenario.setup import prepare_problem

    lines = ["| filter degree | spacecraft | pos RMS after day 1, m | σ RMS, m | err/σ | own NEES in band | verdict | "
             "default q, m²/s³ | run s |",
             "|---|---|---|---|---|---|---|---|---|"]
    scenarios = {}
    for degree in FILTER_DEGREES:
        mapping = formation(degree, days, runs)
        scenario = validate_scenario(mapping, mapping["name"])
        scenarios[degree] = (scenario, yaml.safe_dump(mapping, sort_keys=False))
        problem = prepare_problem(scenario, truth_cache)
        started = time.perf_counter()
        outcomes = tuple(iter_outcomes(problem, runs, jobs=2, progress=False))
        seconds = (time.perf_counter() - started) / runs
        summary = summary_table(CampaignResult(problem, outcomes))
        for name, group in summary.groupby("spacecraft", sort=False):
            ok = group[group.status == "ok"]
            cells = _verdict_cells(ok) if len(ok) else ("–",) * 5
            noise = problem.default_noises[name].psd_m2_s3
            lines.append(f"| {degree} | {name} | {' | '.join(cells)} | {noise:.2g} | {seconds:.1f} |")
        print(lines[-2], lines[-1], sep="\n", flush=True)
    return lines, scenarios


def tune_table(scenarios: dict, runs: int) -> list[str]:
    from liaison_cli.campaign.studies.tuning import DEFAULT_LADDER_M_S2, TuningCase, tune_case

    lines = ["| filter degree | spacecraft | rule's SNC σ_a, m/s² | its q, m²/s³ | pos RMS after day 1, m | err/σ | "
             "own NEES in band | rule |",
             "|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as work:
        for degree in FILTER_DEGREES:
            if degree >= TRUTH_DEGREE:
                continue
            scenario, text = scenarios[degree]
            case = TuningCase(f"degree_{degree}", scenario, text, f"filter degree {degree}")
            table = tune_case(case, DEFAULT_LADDER_M_S2, runs, Path(work), jobs=2)
            chosen = table[table.chosen]
            if chosen.empty:
                lines.append(f"| {degree} | (all) | none on the ladder | | | | | {table.verdict.iloc[0]} |")
                continue
            for row in chosen.to_dict("records"):
                lines.append(f"| {degree} | {row['spacecraft']} | {row['snc_m_s2']:.2g} | {row['psd_m2_s3']:.2g} | "
                             f"{row['error_rms_position_m']:.3g} | {row['position_error_to_sigma']:.2f} | "
                             f"{100 * row['nees_spacecraft_in_band_share']:.0f} % | {row['verdict']} |")
            print(*lines[-len(chosen):], sep="\n", flush=True)
    return lines


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=OUTPUT)
    parser.add_argument("--runs", type=int, default=8)
    parser.add_argument("--days", type=float, default=2.0)
    args = parser.parse_args(argv)
    started = time.perf_counter()
    truth_cache: dict = {}
    defaults, scenarios = defaults_table(args.days, args.runs, truth_cache)
    tuned = tune_table(scenarios, args.runs)
    text = "\n".join([
        f"Written by `python -m benchmarks.lunar_field_truncation --runs {args.runs} --days {args.days:g}`; do not "
        f"edit by hand. NRHO relay (9:2 southern, Gateway) + 100 km polar orbiter, two-way range + range-rate every "
        f"60 s (2.21 m, 11 mm/s), {args.days:g} d, {args.runs} runs, truth GRGM1200A at degree {TRUTH_DEGREE}, every "
        "filter setting at its default; statistics over the epochs after day 1 (the settle time).", "",
        "With the defaults:", "", *defaults, "",
        "`liaison tune`'s rule (its default ladder, the same runs) on each truncated filter:", "", *tuned, "",
        f"Total {time.perf_counter() - started:.0f} s on 2 worker processes."]) + "\n"
    args.output.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
