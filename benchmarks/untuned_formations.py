"""Issue 50's acceptance on formations nobody tuned: writes results/reference/untuned_formations.md.

`python -m benchmarks.untuned_formations [--runs 20] [--drawn 5] [--output FILE]` builds, from documented keys
only and with no `filter` section (every default applies: the step chosen by accuracy, the derived process
noise, the matched range model, initial errors drawn from P0):
- five named formations, each at 60, 300 and 600 s: a DRO with a 100 km polar lunar orbit (range + range-rate),
  the 9:2 NRHO with an elliptical frozen-type lunar orbit (10 m range), a northern L1 halo with a 4,500 km lunar
  orbit, a southern L2 halo with a 200 km lunar orbit (range + range-rate), a DRO, an L2 Lyapunov orbit and an
  elliptical lunar orbit in a mesh;
- the NRHO + elliptical orbit at 300 s and the DRO + 100 km orbit at 600 s again with the former fixed step
  (`filter.rk4_substeps: 4`), for what it cost (left out of the closing count);
- with `--floors`, instead, the named formations at each interval with the process noise set to each value of
  FLOORS_M2_S3 (results/reference/untuned_floor_window.md): the window the default's floor sits in;
- with `--large-sigma N`, instead, the formation that showed the floor's edge (EDGE_CASE) at 60 and 600 s and N
  formations drawn with 100-300 m ranging at 300 or 600 s (results/reference/untuned_large_sigma.md);
- `--drawn` more, drawn from the catalogue with a fixed seed (a family member at a random period, a lunar orbit
  with random elements and a perilune of at least 100 km altitude, a random interval, ranging sigma and
  observables): formations the defaults were not chosen on.
Per case: the runs healthy, each spacecraft's position error RMS after day 1, error / sigma after the settle
time with its 95 % interval, the whole-state NEES share in band and above it, the verdict; the substeps chosen
and the default PSD; and the one-step whitened prediction error on `--recorded` runs (default 2): from the
filter's estimate at every epoch, the filter's own propagation over one interval against a reference (RK8 with
four times the substeps; its error is below 1e-4 of the RK4's), whitened by the spacecraft's 6 x 6 block of the
filter's predicted covariance at the next epoch, its maximum and RMS in sigma over the whole arc and after the
settle time.
"""

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd
from numba import njit

from liaison_cli.analysis.consistency import campaign_verdict
from liaison_cli.campaign.engine.results import summary_table
from liaison_cli.campaign.engine.runner import run_campaign
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import SECONDS_PER_DAY
from liaison_cli.dynamics.ephemeris_dynamics import SENSITIVITY_SIZE, STM_SIZE
from liaison_cli.dynamics.model import propagate_rk8_in_place, propagate_state_stm_into
from liaison_cli.estimation.blocks import BLOCK_SPACECRAFT
from liaison_cli.estimation.estimators import ekf_with_record
from liaison_cli.scenario.loading import validate_scenario
from liaison_cli.scenario.setup import prepare_problem

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "untuned_formations.md"
INTERVALS_S = (60, 300, 600)
REFERENCE_FACTOR = 4
FAMILY_RANGES = {"dro": (3.0, 20.0), "l2_nrho_south": (6.2, 8.0), "l1_halo_north": (9.0, 12.0),
                 "l2_halo_south": (9.0, 14.5), "l2_lyapunov": (16.0, 27.0), "l1_lyapunov": (13.0, 25.0)}
MOON_RADIUS_KM = 1737.4


def _lunar(name, a_km, e, i_deg, raan_deg=0.0, argp_deg=0.0, ta_deg=0.0):
    return {"name": name, "orbit": "lunar_keplerian",
            "elements": {"a_km": a_km, "e": e, "i_deg": i_deg, "raan_deg": raan_deg, "argp_deg": argp_deg,
                         "ta_deg": ta_deg}}


NAMED = {
    "dro_llo100": ([{"name": "DRO", "orbit": "dro", "period_days": 14.0}, _lunar("LLO", 1837.4, 0.0, 90, 30)],
                   {"links": [{"receiver": "DRO", "transponder": "LLO", "observables": ["range", "range_rate"]}]},
                   {"sigma_m": 5.0, "range_rate_sigma_m_s": 0.001}),
    "nrho_elfo": ([{"name": "NRHO", "orbit": "l2_nrho_south", "period_days": 6.5624},
                   _lunar("ELFO", 6142.4, 0.6, 57.7, 0, 90)],
                  {"links": [{"receiver": "NRHO", "transponder": "ELFO"}]}, {"sigma_m": 10.0}),
    "l1halo_lmo": ([{"name": "L1H", "orbit": "l1_halo_north", "period_days": 11.0},
                    _lunar("LMO", 4500, 0.1, 30, 45, 0, 90)],
                   {"links": [{"receiver": "L1H", "transponder": "LMO"}]}, {"sigma_m": 30.0}),
    "l2halo_llo200": ([{"name": "L2H", "orbit": "l2_halo_south", "period_days": 13.0},
                       _lunar("LLO", 1937.4, 0.01, 60, 120)],
                      {"links": [{"receiver": "L2H", "transponder": "LLO", "observables": ["range", "range_rate"]}]},
                      {"sigma_m": 2.0, "range_rate_sigma_m_s": 0.0005}),
    "dro_lyapunov_elfo": ([{"name": "DRO", "orbit": "dro", "period_days": 8.0},
                           {"name": "LYA", "orbit": "l2_lyapunov", "period_days": 18.0},
                           _lunar("ELFO", 5000, 0.5, 80, 10, 270, 180)],
                          {"topology": {"kind": "mesh"}}, {"sigma_m": 20.0}),
}


# The same formations with the former fixed step (4 substeps per interval), for the record of what it cost.
FORMER_STEP = (("nrho_elfo", 300), ("dro_llo100", 600))


def scenario_mapping(name, spacecraft, links, noise, interval_s, runs, duration_days=6.0, seed=11,
                     flt=None) -> dict:
    return {"name": name, "duration_days": duration_days, "spacecraft": spacecraft, **links,
            "measurement": {"interval_s": interval_s}, "noise": noise, "monte_carlo": {"runs": runs, "seed": seed},
            **({"filter": flt} if flt else {})}


RANGING_SIGMAS_M = (1.0, 5.0, 10.0, 30.0, 100.0)
LARGE_RANGING_SIGMAS_M = (100.0, 150.0, 300.0)


def drawn_formations(count: int, seed: int = 50, sigmas_m=RANGING_SIGMAS_M) -> list[tuple[str, dict, float]]:
    """(label, the scenario's spacecraft / links / noise, interval) drawn from the catalogue (module docstring),
    the ranging sigma from sigmas_m."""
    rng = np.random.default_rng(seed)
    out = []
    for index in range(count):
        family = list(FAMILY_RANGES)[rng.integers(len(FAMILY_RANGES))]
        period = float(np.round(rng.uniform(*FAMILY_RANGES[family]), 3))
        perilune_km = MOON_RADIUS_KM + rng.uniform(100.0, 3000.0)
        e = float(np.round(rng.uniform(0.0, 0.6), 3))
        a_km = float(np.round(perilune_km / (1.0 - e), 1))
        lunar = _lunar("Lunar", a_km, e, float(np.round(rng.uniform(0, 180), 1)),
                       float(np.round(rng.uniform(0, 360), 1)), float(np.round(rng.uniform(0, 360), 1)),
                       float(np.round(rng.uniform(0, 360), 1)))
        observables = ["range", "range_rate"] if rng.random() < 0.5 else ["range"]
        noise = {"sigma_m": float(rng.choice(sigmas_m))}
        if "range_rate" in observables:
            noise["range_rate_sigma_m_s"] = float(rng.choice([1e-4, 5e-4, 1e-3]))
        interval = float(rng.choice([60.0, 120.0, 300.0, 600.0]))
        links = {"links": [{"receiver": "Orbiter", "transponder": "Lunar", "observables": observables}]}
        label = f"drawn{index}: {family} {period:g} d + lunar a {a_km:g} km e {e:g}, {'+'.join(observables)}"
        out.append((label, ([{"name": "Orbiter", "orbit": family, "period_days": period}, lunar], links, noise),
                    interval))
    return out


@njit(cache=False)
def _whitened_one_step(model, params, x_hat, p_bar, starts, substeps, dt_tu, reference_factor):
    """(m - 1, S) whitened one-step error per spacecraft: x_hat (m, n) the filter's estimates, p_bar (m, n, n)
    its predicted covariances; the filter's propagator (substeps (S,)) against RK8 with reference_factor times
    the steps."""
    m = x_hat.shape[0]
    out = np.full((m - 1, starts.shape[0]), np.nan)
    y = np.empty(SENSITIVITY_SIZE)
    work = np.empty((5, STM_SIZE))
    k_scratch, tmp = np.empty((12, 6)), np.empty(6)
    state, reference = np.empty(6), np.empty(6)
    for k in range(m - 1):
        for s in range(starts.shape[0]):
            a = starts[s]
            for i in range(6):
                state[i] = x_hat[k, a + i]
                reference[i] = x_hat[k, a + i]
            propagate_state_stm_into(model, params, state, k * dt_tu, dt_tu, substeps[s], y, work)
            propagate_rk8_in_place(model, params, reference, k * dt_tu, dt_tu, reference_factor * substeps[s],
                                   k_scratch, tmp)
            delta = np.empty(6)
            for i in range(6):
                delta[i] = y[i] - reference[i]
            block = np.ascontiguousarray(p_bar[k + 1, a : a + 6, a : a + 6])
            if not np.all(np.isfinite(block)) or block[0, 0] <= 0.0:
                continue
            chol = np.linalg.cholesky(block)
            z = np.linalg.solve(chol, delta)
            out[k, s] = np.sqrt(np.sum(z * z))
    return out


def one_step_check(problem, runs: int) -> tuple[float, float, float, float]:
    """(max, RMS) of the whitened one-step error over every epoch and spacecraft of `runs` runs, whole arc and
    after the settle time."""
    arrays = problem.filter
    kinds, starts = arrays.layout.arrays()[:2]
    spacecraft = np.flatnonzero(kinds == BLOCK_SPACECRAFT)
    settle = problem.times_s[1:] >= problem.scenario.settle_days() * SECONDS_PER_DAY
    whole, settled = [], []
    for run in range(runs):
        inputs = draw_run_inputs(problem, run)
        # A run stopped as diverged keeps its record up to the stop (zeros after it, which the check skips).
        _, states, matrices = ekf_with_record(arrays, inputs.x0_hat, inputs.y_obs, inputs.truth, True)
        values = _whitened_one_step(np.int64(arrays.model), arrays.model_params, states[:, 0, :],
                                    matrices[:, 0, :, :], starts[spacecraft].astype(np.int64),
                                    arrays.substeps[spacecraft].astype(np.int64), arrays.dt_tu,
                                    np.int64(REFERENCE_FACTOR))
        whole.append(values[np.isfinite(values)])
        settled.append(values[settle][np.isfinite(values[settle])])
    whole, settled = np.concatenate(whole), np.concatenate(settled)

    def stats(values):
        return (float(values.max()), float(np.sqrt(np.mean(values**2)))) if len(values) else (np.nan, np.nan)

    return (*stats(whole), *stats(settled))


def evaluate(label: str, mapping: dict, recorded: int) -> list[dict]:
    scenario = validate_scenario(mapping, mapping["name"])
    start = time.perf_counter()
    problem = prepare_problem(scenario)
    result = run_campaign(scenario, jobs=2, progress=False)
    seconds = time.perf_counter() - start
    check = one_step_check(problem, recorded)
    summary = summary_table(result)
    rows = []
    for name, group in summary.groupby("spacecraft", sort=False):
        ok = group[group.status == "ok"]
        verdict = campaign_verdict(ok) if len(ok) else {}
        rows.append({
            "case": label, "interval_s": scenario.measurement.interval_s, "spacecraft": name,
            "runs_ok": f"{len(ok)}/{len(group)}",
            "position_rms_after_day1_m": float(np.sqrt(np.mean(ok.rms_position_settled_m**2))) if len(ok) else np.nan,
            "position_err_to_sigma": verdict.get("position_error_to_sigma_settled", np.nan),
            "halfwidth": verdict.get("position_error_to_sigma_halfwidth", np.nan),
            "nees_in_band": verdict.get("frac_nees_in_band_settled", np.nan),
            "nees_above": verdict.get("frac_nees_above_band_settled", np.nan),
            "consistent": bool(verdict.get("consistent_settled", False)),
            "substeps": problem.step_choices[name].substeps,
            "default_psd_m2_s3": problem.default_noises[name].psd_m2_s3 if name in problem.default_noises else np.nan,
            "one_step_max_sigma": check[0], "one_step_rms_sigma": check[1],
            "one_step_max_settled_sigma": check[2], "one_step_rms_settled_sigma": check[3],
            "seconds": seconds})
    return rows


def to_markdown(table: pd.DataFrame, command: str) -> str:
    lines = [f"Written by `{command}`; do not edit by hand. Every default applies (no `filter` "
             "section). Position error RMS after day 1 over the healthy runs; err/σ: position error RMS / σ RMS after "
             "the settle time with its 95 % interval; NEES: share of settled epochs with the whole-state NEES in the "
             "single-run 95 % band (85 % needed) and above it; one-step: the whitened one-step prediction error "
             "(filter propagator vs RK8 at 4x the steps, by the predicted covariance), max / RMS in σ over the whole "
             "arc and after the settle time.\n",
             "| case | dt s | spacecraft | runs ok | pos RMS >1 d m | err/σ | NEES in | above | consistent | substeps | "
             "default q m²/s³ | one-step max / RMS σ | settled max / RMS σ |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in table.to_dict("records"):
        lines.append(
            f"| {row['case']} | {row['interval_s']:g} | {row['spacecraft']} | {row['runs_ok']} | "
            f"{row['position_rms_after_day1_m']:.3g} | {row['position_err_to_sigma']:.2f}±{row['halfwidth']:.2f} | "
            f"{100 * row['nees_in_band']:.0f} % | {100 * row['nees_above']:.0f} % | "
            f"{'yes' if row['consistent'] else 'no'} | {row['substeps']} | {row['default_psd_m2_s3']:.2g} | "
            f"{row['one_step_max_sigma']:.2g} / {row['one_step_rms_sigma']:.2g} | "
            f"{row['one_step_max_settled_sigma']:.2g} / {row['one_step_rms_settled_sigma']:.2g} |")
    table = table[~table.case.str.contains("former")]
    cases = table.groupby(["case", "interval_s"])
    consistent = sum(bool(g.consistent.all()) for _, g in cases)
    named = table[table.case.isin(list(NAMED))]
    if len(named):
        error = named.pivot_table(index=["case", "spacecraft"], columns="interval_s",
                                  values="position_rms_after_day1_m")
        not_worse = int((error[60] <= error[600]).sum()) if {60, 600} <= set(error.columns) else 0
        lines.append(f"\nError after day 1 at 60 s not above that at 600 s: {not_worse} of {len(error)} spacecraft of "
                     "the named formations.")
    lines.append(f"\n{consistent} of {len(cases)} cases consistent for every spacecraft; largest one-step error "
                 f"{table.one_step_max_sigma.max():.2g} σ (whole arc), {table.one_step_max_settled_sigma.max():.2g} σ "
                 "after the settle time.")
    return "\n".join(lines) + "\n"


LARGE_SIGMA_OUTPUT = REPO / "results" / "reference" / "untuned_large_sigma.md"
# The formation that showed the floor's edge (issue 50's closing note): the crosslink-pair template's EML2 halo with
# its orbiter moved to a = 3,000 km, e = 0.4 (63 km perilune altitude), 150 m ranging every 600 s over 4 days.
EDGE_CASE = ([{"name": "EML2", "orbit": "eml2_halo"}, _lunar("Lunar", 3000, 0.4, 60)],
             {"links": [{"receiver": "EML2", "transponder": "Lunar", "observables": ["range"]}]}, {"sigma_m": 150.0})


def large_sigma_rows(drawn: int, runs: int, recorded: int) -> list[dict]:
    """The edge case at 60 and 600 s, then `drawn` formations drawn as in drawn_formations with ranging sigma from
    LARGE_RANGING_SIGMAS_M and a 300 or 600 s interval (another seed): where the default's floor stops holding."""
    rows = []
    spacecraft, links, noise = EDGE_CASE
    for interval in (60, 600):
        rows += evaluate("edge: EML2 halo + lunar a 3000 km e 0.4, range, 150 m", scenario_mapping(
            f"edge_{interval}", spacecraft, links, noise, interval, runs, duration_days=4.0), recorded)
    for index, (label, (spacecraft, links, noise), interval) in enumerate(
            drawn_formations(drawn, seed=51, sigmas_m=LARGE_RANGING_SIGMAS_M)):
        interval = 300.0 if interval < 300.0 else interval
        rows += evaluate(f"{label}, {noise['sigma_m']:g} m", scenario_mapping(
            f"large{index}", spacecraft, links, noise, interval, runs), recorded)
        print(label, "done", flush=True)
    return rows


FLOOR_OUTPUT = REPO / "results" / "reference" / "untuned_floor_window.md"
FLOORS_M2_S3 = (1e-22, 1e-20, 1e-19, 1e-18, 3e-18, 1e-17, 1e-16, 1e-15)


def floor_window(runs: int, floors=FLOORS_M2_S3) -> pd.DataFrame:
    """The named formations at each interval with the process noise set to each floor (every other default
    kept): per case and floor, the smallest whole-state NEES share in band over its spacecraft, the largest share
    above the band, and whether every spacecraft passes the verdict."""
    rows = []
    for name, (spacecraft, links, noise) in NAMED.items():
        for interval in INTERVALS_S:
            for floor in floors:
                mapping = scenario_mapping(f"{name}_{interval}", spacecraft, links, noise, interval, runs,
                                           flt={"process_noise_psd_m2_s3": floor})
                summary = summary_table(run_campaign(validate_scenario(mapping, mapping["name"]), jobs=2,
                                                     progress=False))
                verdicts = [campaign_verdict(g[g.status == "ok"]) if (g.status == "ok").any() else None
                            for _, g in summary.groupby("spacecraft", sort=False)]
                ok = all(v is not None for v in verdicts)
                rows.append({"case": name, "interval_s": interval, "floor_m2_s3": floor,
                             "in_band": min(v["frac_nees_in_band_settled"] for v in verdicts) if ok else np.nan,
                             "above": max(v["frac_nees_above_band_settled"] for v in verdicts) if ok else np.nan,
                             "consistent": ok and all(v["consistent_settled"] for v in verdicts)})
    return pd.DataFrame(rows)


def floor_markdown(table: pd.DataFrame, command: str) -> str:
    floors = sorted(table.floor_m2_s3.unique())
    lines = [f"Written by `{command}`; do not edit by hand. The named formations with "
             "filter.process_noise_psd_m2_s3 set to each value, every other default kept (the step chosen by "
             "accuracy): the whole-state NEES share in band after the settle time (the smallest over the "
             "spacecraft), with 'yes' where every spacecraft passes the verdict and '↑' where more than 10 % of "
             "settled epochs lie above the band (optimistic).\n",
             "| case | dt s | " + " | ".join(f"{q:g}" for q in floors) + " |",
             "|---|---|" + "---|" * len(floors)]
    for (case, interval), part in table.groupby(["case", "interval_s"], sort=False):
        cells = []
        for q in floors:
            row = part[part.floor_m2_s3 == q].iloc[0]
            mark = "yes" if row.consistent else "no"
            mark += " ↑" if row.above > 0.10 else ""
            cells.append(f"{100 * row.in_band:.0f} % {mark}")
        lines.append(f"| {case} | {interval:g} | " + " | ".join(cells) + " |")
    passing = table.groupby("floor_m2_s3").consistent.agg(["sum", "count"])
    lines.append("\nCases consistent per value: " + ", ".join(
        f"{q:g}: {int(r['sum'])}/{int(r['count'])}" for q, r in passing.iterrows()) + ".")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--drawn", type=int, default=5)
    parser.add_argument("--recorded", type=int, default=2)
    parser.add_argument("--output", type=Path, default=OUTPUT)
    parser.add_argument("--floors", action="store_true", help="instead, the process-noise window: "
                        "results/reference/untuned_floor_window.md")
    parser.add_argument("--large-sigma", type=int, default=0, metavar="N",
                        help="instead, the edge case and N formations drawn with 100-300 m ranging: "
                        "results/reference/untuned_large_sigma.md")
    args = parser.parse_args(argv)
    if args.large_sigma:
        command = f"python -m benchmarks.untuned_formations --large-sigma {args.large_sigma}" + (
            f" --runs {args.runs}" if args.runs != 20 else "")
        LARGE_SIGMA_OUTPUT.write_text(to_markdown(pd.DataFrame(large_sigma_rows(args.large_sigma, args.runs,
                                                                                args.recorded)), command))
        print(LARGE_SIGMA_OUTPUT.read_text())
        return
    if args.floors:
        FLOOR_OUTPUT.write_text(floor_markdown(floor_window(args.runs), "python -m benchmarks.untuned_formations "
                                               "--floors" + (f" --runs {args.runs}" if args.runs != 20 else "")))
        print(FLOOR_OUTPUT.read_text())
        return
    rows = []
    for name, (spacecraft, links, noise) in NAMED.items():
        for interval in INTERVALS_S:
            label = f"{name}"
            rows += evaluate(label, scenario_mapping(f"{name}_{interval}", spacecraft, links, noise, interval,
                                                     args.runs), args.recorded)
            print(rows[-1]["case"], interval, "done", flush=True)
    for name, interval in FORMER_STEP:
        spacecraft, links, noise = NAMED[name]
        rows += evaluate(f"{name}, former fixed 4 substeps", scenario_mapping(
            f"{name}_{interval}_former", spacecraft, links, noise, interval, args.runs, flt={"rk4_substeps": 4}),
            args.recorded)
    for index, (label, (spacecraft, links, noise), interval) in enumerate(drawn_formations(args.drawn)):
        rows += evaluate(label, scenario_mapping(f"drawn{index}", spacecraft, links, noise, interval, args.runs),
                         args.recorded)
        print(label, "done", flush=True)
    table = pd.DataFrame(rows)
    command = "python -m benchmarks.untuned_formations" + (f" --runs {args.runs}" if args.runs != 20 else "")
    args.output.write_text(to_markdown(table, command))
    print(args.output.read_text())


if __name__ == "__main__":
    main()
