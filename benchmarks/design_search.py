"""Issue 48's acceptance for `liaison design`: writes results/reference/design_search.md.

`python -m benchmarks.design_search [--runs 30] [--candidates N]` for two formations, 10 days of range every
187.5 s (every default otherwise):
- A: a user in a 3,000 km lunar orbit (e = 0.1, i = 60 deg), its relay open on the DRO family, 4 to 20 d x 4
  phases (20 candidates); objective: the user's position error RMS after the settle time;
- B: a spacecraft on the EML2 halo of Turan et al., its partner open on the L2 Lyapunov family, 15 to 28 d x 4
  phases (20 candidates); objective: the worse of the two.
Per formation: every candidate scored by LinCov on 2 cores (the wall time and candidates per second), then every
candidate run by Monte Carlo (`--runs`, default 30), and Spearman's rank correlation between the LinCov score and
the Monte Carlo RMS, with the largest Monte Carlo / LinCov ratio. With `--candidates N`, the throughput of a grid
of N candidates of formation A (N / 4 periods x 4 phases) instead, cold (a fresh family table) is not separated.
"""

import argparse
import time
from pathlib import Path

import numpy as np

from liaison_cli.campaign.engine.backends import LOCAL
from liaison_cli.campaign.studies.design import condition_agreement, make_design, rank_agreement, score_all, verify

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "design_search.md"

USER = {"name": "User", "orbit": "lunar_keplerian",
        "elements": {"a_km": 3000, "e": 0.1, "i_deg": 60, "raan_deg": 0, "argp_deg": 0, "ta_deg": 0}}
FORMATIONS = {
    "A: lunar user, relay on a DRO": ([{"name": "Relay", "orbit": "dro", "period_days": 12.0}, USER], "Relay",
                                      "dro", "4:20:5", "User"),
    "B: EML2 halo, partner on an L2 Lyapunov": ([{"name": "Halo", "orbit": "eml2_halo"},
                                                 {"name": "Partner", "orbit": "l2_lyapunov", "period_days": 20.0}],
                                                "Partner", "l2_lyapunov", "15:28:5", "worst"),
}


def base_mapping(spacecraft, runs: int) -> dict:
    first, second = spacecraft[0]["name"], spacecraft[1]["name"]
    return {"name": "design_bench", "duration_days": 10.0, "spacecraft": spacecraft,
            "links": [{"receiver": first, "transponder": second, "observables": ["range"]}],
            "measurement": {"interval_s": 187.5}, "noise": {"sigma_m": 10.0}, "monte_carlo": {"runs": runs, "seed": 48}}


def formation_rows(runs: int, jobs: int = 2) -> list[str]:
    lines = ["| formation | candidates | LinCov wall s (2 cores) | candidates / s | Monte Carlo runs each | "
             "Spearman ρ | MC / LinCov range | best (period d, phase) LinCov / MC | ρ condition number / LinCov |",
             "|---|---|---|---|---|---|---|---|---|"]
    for label, (spacecraft, open_name, family, periods, objective) in FORMATIONS.items():
        design = make_design(base_mapping(spacecraft, runs), open_name, objective, family, periods, 4)
        conditioned = make_design(base_mapping(spacecraft, runs), open_name, objective, family, periods, 4, True)
        score_all(make_design(base_mapping(spacecraft, runs), open_name, objective, family, "10:10:1", 1)
                  if family == "dro" else make_design(base_mapping(spacecraft, runs), open_name, objective, family,
                                                      "20:20:1", 1), 1, LOCAL)  # compile and load once
        start = time.perf_counter()
        table = score_all(design, jobs, LOCAL)
        seconds = time.perf_counter() - start
        checked = verify(design, table, len(table), runs, jobs, LOCAL)
        scored = checked[checked.mc_score_m.notna()]
        ratio = scored.mc_over_lincov
        best_lincov = checked.iloc[0]
        best_mc = scored.sort_values("mc_score_m").iloc[0]
        lines.append(f"| {label} | {len(table)} | {seconds:.1f} | {len(table) / seconds:.2f} | {runs} | "
                     f"{rank_agreement(checked):.2f} | {ratio.min():.2f}–{ratio.max():.2f} | "
                     f"({best_lincov.period_days:g}, {best_lincov.phase:g}) / ({best_mc.period_days:g}, "
                     f"{best_mc.phase:g}) | {condition_agreement(score_all(conditioned, jobs, LOCAL)):.2f} |")
        print(lines[-1], flush=True)
    return lines


def throughput(count: int, jobs: int = 2) -> str:
    spacecraft, open_name, family, _, objective = FORMATIONS["A: lunar user, relay on a DRO"]
    periods = max(1, count // 4)
    design = make_design(base_mapping(spacecraft, 2), open_name, objective, family, f"4:20:{periods}", 4)
    start = time.perf_counter()
    table = score_all(design, jobs, LOCAL)
    seconds = time.perf_counter() - start
    return (f"{len(table)} candidates of formation A on {jobs} cores: {seconds:.1f} s, "
            f"{len(table) / seconds:.2f} candidates / s, {int(np.sum(table.error != ''))} not scored")


THROUGHPUT = REPO / "results" / "reference" / "design_throughput.md"


def throughput_table(count: int, jobs: int = 2) -> list[str]:
    """The N-candidate search of formation A, same session: local processes with every truth flown
    (LIAISON_TRUTH_CACHE=off), once more with the disk truth cache filling, then warm (every truth read back),
    then on a dask LocalCluster of `jobs` separate worker processes (warm), and whether its table equals the
    local one. The compiled code is cached throughout (compile once first)."""
    import os

    from liaison_cli.campaign.engine.backends import Backend

    spacecraft, open_name, family, _, objective = FORMATIONS["A: lunar user, relay on a DRO"]
    design = make_design(base_mapping(spacecraft, 2), open_name, objective, family, f"4:20:{max(1, count // 4)}", 4)
    start = time.perf_counter()
    score_all(make_design(base_mapping(spacecraft, 2), open_name, objective, family, "10:10:1", 1), 1, LOCAL)
    rows, tables = [f"| one candidate in this process first (compiling what the cache lacks) | 1 | "
                    f"{time.perf_counter() - start:.1f} | |"], {}
    for label, truths, where in (("local, every truth flown", "off", LOCAL), ("local, truth cache filling", "on", LOCAL),
                                 ("local, truths from the cache", "on", LOCAL),
                                 ("dask LocalCluster, truths from the cache", "on", Backend("dask"))):
        os.environ["LIAISON_TRUTH_CACHE"] = truths
        start = time.perf_counter()
        tables[label] = score_all(design, jobs, where)
        seconds = time.perf_counter() - start
        rows.append(f"| {label} | {len(tables[label])} | {seconds:.1f} | {len(tables[label]) / seconds:.2f} |")
        print(rows[-1], flush=True)
    local, dask = tables["local, truths from the cache"], tables["dask LocalCluster, truths from the cache"]
    same = local.drop(columns=["error"]).equals(dask.drop(columns=["error"])) and list(local.error) == list(dask.error)
    first = tables["local, every truth flown"]
    flown_same = first.score_m.equals(local.score_m)
    return [f"Written by `python -m benchmarks.design_search --throughput {count}`; do not edit by hand. Formation A "
            f"(lunar user, relay on a DRO; 10 d of range every 187.5 s), {len(design.candidates)} candidates "
            f"({max(1, count // 4)} periods x 4 phases) on {jobs} cores, LinCov scores only; {os.cpu_count()} cores "
            "on this machine.", "",
            "| run | candidates | wall s | candidates / s |", "|---|---|---|---|", *rows, "",
            f"The dask table equals the local one, every column: **{'yes' if same else 'no'}**. Scores with every "
            f"truth flown equal those from the truth cache: **{'yes' if flown_same else 'no'}**."]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--candidates", type=int, default=0)
    parser.add_argument("--throughput", type=int, default=0, metavar="N",
                        help="the N-candidate search cold, warm and on dask, into results/reference/design_throughput.md")
    args = parser.parse_args(argv)
    if args.throughput:
        text = "\n".join(throughput_table(args.throughput))
        THROUGHPUT.write_text(text + "\n")
        print(text)
        return
    if args.candidates:
        print(throughput(args.candidates))
        return
    lines = formation_rows(args.runs)
    text = "\n".join(["Written by `python -m benchmarks.design_search`; do not edit by hand. Two formations, 10 d "
                      "of range every 187.5 s (10 m), every other default; each candidate scored by LinCov on its "
                      "objective's position error RMS after the settle time, then run by Monte Carlo.", "", *lines])
    OUTPUT.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
