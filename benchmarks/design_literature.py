"""Issue 48's literature check on the design search: the sign of the coplanarity effect on a relay pair (more
coplanar relays determine their orbits worse). Writes results/reference/design_coplanarity.md.

    python -m benchmarks.design_literature [--runs 30]

Two lunar relays on 6,000 km orbits (e = 0.05, i = 60 deg, a quarter of an orbit apart), 10 days of crosslink
range every 300 s (10 m), every other setting the defaults; the design search (`liaison design --vary`) varies
the second relay's plane in two readings of "less coplanar": its node (raan) 0-90 deg, and its inclination 60-0
deg. Each candidate: the mutual inclination of the two planes, the LinCov position error RMS after the settle
time of the worse relay and its filter sigma RMS, the 30-run Monte Carlo RMS with the consistency verdict, and the
condition number of the range information matrix (liaison observability's). Spearman's rho between the mutual
inclination and each measure says whether the sign holds (negative: more coplanar, worse).
"""

import argparse
import math
from pathlib import Path

import numpy as np

from liaison_cli.campaign.engine.backends import LOCAL
from liaison_cli.campaign.studies.design import make_design, score_all, verify

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "design_coplanarity.md"
RELAY = {"a_km": 6000, "e": 0.05, "i_deg": 60, "raan_deg": 0, "argp_deg": 0, "ta_deg": 0}
BASE = {"name": "coplanarity", "duration_days": 10.0,
        "spacecraft": [{"name": "A", "orbit": "lunar_keplerian", "elements": dict(RELAY)},
                       {"name": "B", "orbit": "lunar_keplerian", "elements": {**RELAY, "ta_deg": 90}}],
        "links": [{"receiver": "A", "transponder": "B", "observables": ["range"]}],
        "measurement": {"interval_s": 300}, "noise": {"sigma_m": 10.0}, "monte_carlo": {"runs": 30, "seed": 48}}
READINGS = {"the second relay's node": ("spacecraft.1.elements.raan_deg", [0, 5, 15, 30, 60, 90]),
            "the second relay's inclination": ("spacecraft.1.elements.i_deg", [60, 55, 45, 30, 0])}


def mutual_inclination_deg(key: str, value: float) -> float:
    """The angle between the two orbit planes (both at i = 60 deg, nodes apart by the raan; or one at i)."""
    i = math.radians(RELAY["i_deg"])
    if key.endswith("raan_deg"):
        return math.degrees(math.acos(np.clip(math.cos(i) ** 2 + math.sin(i) ** 2 * math.cos(math.radians(value)),
                                              -1.0, 1.0)))
    return abs(RELAY["i_deg"] - value)


def reading_rows(label: str, key: str, values: list, runs: int, jobs: int) -> list[str]:
    from scipy.stats import spearmanr

    design = make_design({**BASE, "monte_carlo": {"runs": runs, "seed": 48}}, None, "worst", None, None, 1, True,
                         [(key, values)])
    table = verify(design, score_all(design, jobs, LOCAL), len(values), runs, jobs, LOCAL)
    table["mutual_deg"] = [mutual_inclination_deg(key, v) for v in table[key]]
    table = table.sort_values("mutual_deg")
    lines = []
    for row in table.to_dict("records"):
        sigma = max(row["A_sigma_position_m"], row["B_sigma_position_m"])
        lines.append(f"| {label} | {row[key]:g} | {row['mutual_deg']:.1f} | {row['score_m']:.1f} | {sigma:.1f} | "
                     f"{row['mc_score_m']:.1f} | {row['mc_runs_ok']} | {row['mc_consistent']} | "
                     f"{row['range_condition_number']:.2e} |")
    rho = {name: spearmanr(table.mutual_deg, table[column]).statistic
           for name, column in (("LinCov", "score_m"), ("Monte Carlo", "mc_score_m"),
                                ("condition number", "range_condition_number"))}
    lines.append(f"| {label}: Spearman ρ against the mutual inclination | | | "
                 + " | ".join(f"{name} {value:+.2f}" for name, value in rho.items()) + " | | | | |")
    return lines


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    lines = [f"Written by `python -m benchmarks.design_literature --runs {args.runs}`; do not edit by hand. Two lunar "
             "relays (a = 6,000 km, e = 0.05, i = 60 deg, a quarter orbit apart), 10 d of crosslink range every 300 s "
             "at 10 m, default filter; settle time 1 d. Errors are the worse relay's position error RMS after the "
             "settle time; sigma its filter sigma RMS.", "",
             "| varied | value (deg) | mutual inclination (deg) | LinCov RMS m | filter σ RMS m | Monte Carlo RMS m | "
             "runs ok | consistent | range condition number |", "|---|---|---|---|---|---|---|---|---|"]
    for label, (key, values) in READINGS.items():
        rows = reading_rows(label, key, values, args.runs, args.jobs)
        lines += rows
        print("\n".join(rows), flush=True)
    OUTPUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUTPUT}")


if __name__ == "__main__":
    main()
