"""The Moon's field in the CRTBP, measured: writes results/reference/lunar_field.md.

`python -m benchmarks.lunar_field` reports, for GRGM1200A truncated to several degrees:
- the RMS of the harmonics' acceleration (beyond the point mass) over a sphere at 100 km and 1,000 km altitude
  (2,000 points of a Fibonacci lattice), and the RMS of what the degrees above 8 and above 20 add;
- the frame approximation: the CRTBP holds the Moon's principal axes on the rotating frame, while the real Moon
  turns against the Earth-Moon line by up to about 7.9 degrees in longitude (its eccentric orbit) and 6.7 in
  latitude (its equator's tilt to the orbit). The RMS of the acceleration change when the field is turned by
  those angles (about z, about y), against the field's own RMS;
- the cost of one evaluation of the acceleration, and of the acceleration with its gradient (the STM's), called from
  compiled code at 2,000 points 100 km up, in microseconds, against the point-mass CRTBP derivative called the same
  way in the same session;
- the truth's propagation with the field: a 100 km polar orbit over one day at degree 100, the truth's RK8 (its
  step halved from 60 s until its Richardson error meets the truth's tolerance) against scipy's DOP853 at rtol
  1e-12 on the same field;
- the filter's field against the truth's: a DRO and a 100 km polar orbit (range + range-rate every 60 s, 5 m and
  1 mm/s, 2 days, 8 runs, every default) under a degree-20 truth, with the filter at degree 0 (a point-mass Moon),
  8 and 20: position error RMS after day 1, err/σ, the verdict and the default process noise;
- with `--per-run`, instead (printed, not written): one EKF run's whole work unit (execute_run, median of 5 on one
  core after compilation) of a 10-day NRHO relay + 100 km polar orbiter at 60 s with the filter at degree 20 and
  the truth at 100, per epoch, against the shipped eml2_lunar's in the same session.
"""

import argparse
import time
from pathlib import Path

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import MU
from liaison_cli.dynamics.crtbp import derivative
from liaison_cli.dynamics.lunar_gravity import lunar_field
from liaison_cli.dynamics.spherical_harmonics import (field_acceleration_into, field_payload, packed_index,
                                                       payload_tables)

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "lunar_field.md"
DEGREES = (2, 8, 20, 50, 100, 200)
ALTITUDES_KM = (100.0, 1000.0)
LIBRATION_LONGITUDE_DEG, LIBRATION_LATITUDE_DEG = 7.9, 6.7
MOON_RADIUS_KM = 1737.4


def sphere(count: int, radius_km: float) -> np.ndarray:
    """(count, 3) points of a Fibonacci lattice on a sphere."""
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    phi = np.pi * (1.0 + 5.0**0.5) * k
    rho = np.sqrt(1.0 - z * z)
    return radius_km * np.column_stack([rho * np.cos(phi), rho * np.sin(phi), z])


def tables(field, degree):
    """The field's evaluation tables truncated to `degree`, built once (as the propagators carry them)."""
    size = packed_index(degree, degree) + 1
    return payload_tables(field_payload(field.c[:size], field.s[:size], degree, field.radius_km))[2]


def accelerations(field, degree, points) -> np.ndarray:
    acc, grad = np.empty(3), np.empty(6)
    out = np.empty((len(points), 3))
    field_tables = tables(field, degree)
    for i, p in enumerate(points):
        field_acceleration_into(field_tables, field.gm_km3_s2, field.radius_km, degree, p[0], p[1], p[2], False, acc,
                                grad)
        out[i] = acc
    return out * 1e3  # m/s^2


def rotation(axis: int, angle_deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def rms(values) -> float:
    return float(np.sqrt(np.mean(np.sum(values**2, axis=1))))


def turned(field, degree, points, r) -> np.ndarray:
    """The field turned by r: its acceleration at p is r a(r^T p)."""
    return accelerations(field, degree, points @ r) @ r.T


@njit(cache=True)
def _evaluate_all(field_tables, gm, radius, degree, points, with_gradient, acc, grad):
    for i in range(points.shape[0]):
        field_acceleration_into(field_tables, gm, radius, degree, points[i, 0], points[i, 1], points[i, 2],
                                with_gradient, acc, grad)


def cost_us(field, degree, with_gradient: bool, calls: int = 2000) -> float:
    """One evaluation as the propagators make it (the field's tables built once, the calls from compiled code), at
    `calls` points of a sphere 100 km above the reference radius, µs: the best of three passes."""
    acc, grad = np.empty(3), np.empty(6)
    field_tables = tables(field, degree)
    points = sphere(calls, field.radius_km + 100.0)
    best = float("inf")
    for _ in range(4):  # the first pass compiles
        start = time.perf_counter()
        _evaluate_all(field_tables, field.gm_km3_s2, field.radius_km, degree, points, with_gradient, acc, grad)
        best = min(best, time.perf_counter() - start)
    return best / calls * 1e6


@njit(cache=True)
def _point_mass_all(states, mu):
    total = 0.0
    for i in range(states.shape[0]):
        total += derivative(states[i], mu)[3]
    return total


def point_mass_cost_us(calls: int = 2000) -> float:
    """The point-mass CRTBP derivative, called as cost_us calls the field (from compiled code, best of three), µs."""
    states = np.tile(np.array([0.99, 0.001, 0.002, 0.0, 0.3, 0.1]), (calls, 1))
    states[:, 0] += np.linspace(0.0, 1e-3, calls)
    best = float("inf")
    for _ in range(4):  # the first pass compiles
        start = time.perf_counter()
        _point_mass_all(states, MU)
        best = min(best, time.perf_counter() - start)
    return best / calls * 1e6


def measure(points_count: int = 2000) -> list[str]:
    top = max(DEGREES)
    field = lunar_field(top)
    lines = ["| altitude km | degree | harmonics RMS m/s² | beyond 8 | beyond 20 | turned 7.9° in longitude | "
             "turned 6.7° in latitude |", "|---|---|---|---|---|---|---|"]
    for altitude in ALTITUDES_KM:
        points = sphere(points_count, MOON_RADIUS_KM + altitude)
        by_degree = {d: accelerations(field, d, points) for d in DEGREES if d <= 100}
        for degree, acc in by_degree.items():
            beyond8 = rms(acc - by_degree[8]) if degree > 8 else 0.0
            beyond20 = rms(acc - by_degree[20]) if degree > 20 else 0.0
            longitude = rms(turned(field, degree, points, rotation(2, LIBRATION_LONGITUDE_DEG)) - acc)
            latitude = rms(turned(field, degree, points, rotation(1, LIBRATION_LATITUDE_DEG)) - acc)
            size = rms(acc)
            lines.append(f"| {altitude:g} | {degree} | {size:.3g} | {beyond8:.3g} | {beyond20:.3g} | "
                         f"{longitude:.3g} ({longitude / size:.0%}) | {latitude:.3g} ({latitude / size:.0%}) |")
    base = point_mass_cost_us()
    lines += ["", f"Cost of one evaluation, µs (the point-mass CRTBP derivative: {base:.2f} µs in the same session):",
              "", "| degree | acceleration | with its gradient |", "|---|---|---|"]
    for degree in DEGREES:
        lines.append(f"| {degree} | {cost_us(field, degree, False):.1f} | {cost_us(field, degree, True):.1f} |")
    return lines


def truth_against_dop853(degree: int = 100) -> list[str]:
    from scipy.integrate import solve_ivp

    from liaison_cli.dynamics.constants import LU_KM, M_PER_LU, SECONDS_PER_DAY, TU_S
    from liaison_cli.dynamics.crtbp_field import field_derivative
    from liaison_cli.dynamics.model import crtbp_model

    r = (MOON_RADIUS_KM + 100.0) / LU_KM
    state = np.array([1.0 - MU + r, 0.0, 0.0, 0.0, -r, np.sqrt(MU / r)])  # polar: inertial v along z
    model = crtbp_model(MU, moon_degree=degree)
    times = np.arange(0.0, SECONDS_PER_DAY + 1.0, 600.0) / TU_S
    start = time.perf_counter()
    truth = model.truth_states(state, times)
    truth_s = time.perf_counter() - start
    start = time.perf_counter()
    reference = solve_ivp(lambda t, y: field_derivative(y, model.params), (0.0, times[-1]), state, method="DOP853",
                          rtol=1e-12, atol=1e-15, t_eval=times).y.T
    reference_s = time.perf_counter() - start
    error_m = np.linalg.norm(truth[:, :3] - reference[:, :3], axis=1) * M_PER_LU
    return [f"A 100 km polar orbit over one day with the field at degree {degree}: the truth's RK8 is "
            f"{error_m.max():.3g} m from DOP853 (rtol 1e-12) at worst ({truth_s:.1f} s against {reference_s:.1f} s)."]


FILTER_DEGREES = (0, 8, 20)
TRUTH_DEGREE = 20


def settled_figures(summary):
    """Per spacecraft of a campaign's summary table: (name, position RMS after the settle time m, err/σ, its 95 %
    half-width, the share of epochs with its own NEES in band, consistent) over the runs that finished."""
    from liaison_cli.analysis.consistency import campaign_verdict

    for name, group in summary.groupby("spacecraft", sort=False):
        ok = group[group.status == "ok"]
        verdict = campaign_verdict(ok)
        yield (name, float(np.sqrt(np.mean(ok.rms_position_settled_m**2))),
               verdict["position_error_to_sigma_settled"], verdict["position_error_to_sigma_halfwidth"],
               verdict["frac_nees_spacecraft_in_band_settled"], bool(verdict["consistent_settled"]))


def filter_study(runs: int = 8) -> list[str]:
    from liaison_cli.campaign.engine.results import summary_table
    from liaison_cli.campaign.engine.runner import run_campaign
    from liaison_cli.scenario.loading import validate_scenario

    lines = ["| filter degree | spacecraft | pos RMS >1 d m | err/σ | NEES own in band | consistent | "
             "default q m²/s³ |",
             "|---|---|---|---|---|---|---|"]
    for degree in FILTER_DEGREES:
        mapping = {"name": f"field_{degree}", "duration_days": 2.0,
                   "spacecraft": [{"name": "DRO", "orbit": "dro", "period_days": 14.0},
                                  {"name": "LLO", "orbit": "lunar_keplerian",
                                   "elements": {"a_km": 1837.4, "e": 0.0, "i_deg": 90, "raan_deg": 30, "argp_deg": 0,
                                                "ta_deg": 0}}],
                   "links": [{"receiver": "DRO", "transponder": "LLO", "observables": ["range", "range_rate"]}],
                   "measurement": {"interval_s": 60}, "noise": {"sigma_m": 5.0, "range_rate_sigma_m_s": 0.001},
                   "moon_gravity": {"degree": TRUTH_DEGREE, "filter_degree": degree},
                   "monte_carlo": {"runs": runs, "seed": 1}}
        scenario = validate_scenario(mapping, mapping["name"])
        result = run_campaign(scenario, jobs=2, progress=False)
        noises = result.problem.default_noises  # as the campaign flew it: the rule, LinCov-checked
        summary = summary_table(result)
        for name, rms_m, ratio, halfwidth, in_band, consistent in settled_figures(summary):
            lines.append(f"| {degree} | {name} | {rms_m:.3g} | {ratio:.2f}±{halfwidth:.2f} | {100 * in_band:.0f} % | "
                         f"{'yes' if consistent else 'no'} | {noises[name].psd_m2_s3:.2g} |")
    return lines


def per_run_seconds(scenario, repeats: int = 5) -> tuple[float, int]:
    """(median seconds of execute_run after a first compiling run, epochs per run)."""
    from liaison_cli.campaign.engine.worker import RunTask, execute_run
    from liaison_cli.scenario.setup import prepare_problem

    problem = prepare_problem(scenario)
    execute_run(problem, RunTask(0))
    times = []
    for run in range(1, repeats + 1):
        start = time.perf_counter()
        execute_run(problem, RunTask(run))
        times.append(time.perf_counter() - start)
    return float(np.median(times)), len(problem.times_s)


def per_run_comparison() -> str:
    from liaison_cli.scenario.loading import load_scenario, validate_scenario

    relay = {"name": "relay_per_run", "duration_days": 10.0,
             "spacecraft": [{"name": "Relay", "orbit": "nrho_gateway"},
                            {"name": "User", "orbit": "lunar_keplerian",
                             "elements": {"altitude_km": 100.0, "e": 0.0, "i_deg": 90.0, "raan_deg": 30.0}}],
             "links": [{"receiver": "Relay", "transponder": "User", "observables": ["range", "range_rate"]}],
             "measurement": {"interval_s": 60}, "noise": {"sigma_m": 2.21, "range_rate_sigma_m_s": 0.011},
             "moon_gravity": {"degree": 100, "filter_degree": 20}, "monte_carlo": {"runs": 6, "seed": 1}}
    field_s, field_epochs = per_run_seconds(validate_scenario(relay, "relay_per_run"))
    base_s, base_epochs = per_run_seconds(load_scenario(REPO / "scenarios" / "eml2_lunar.yaml")[0])
    ratio = (field_s / field_epochs) / (base_s / base_epochs)
    return (f"one run, median of 5 on one core: NRHO relay + 100 km orbiter, filter degree 20 / truth 100, 10 d at "
            f"60 s: {field_s:.2f} s ({field_s / field_epochs * 1e6:.0f} µs per epoch); eml2_lunar: {base_s:.3f} s "
            f"({base_s / base_epochs * 1e6:.0f} µs per epoch); per epoch {ratio:.1f}x")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output", type=Path, default=OUTPUT)
    parser.add_argument("--per-run", action="store_true", help="instead, the per-run time against eml2_lunar")
    args = parser.parse_args(argv)
    if args.per_run:
        print(per_run_comparison())
        return
    text = "\n".join(["Written by `python -m benchmarks.lunar_field`; do not edit by hand. GRGM1200A's harmonics "
                      "beyond the point mass, over 2,000 points on a sphere at each altitude.", "", *measure(), "", *truth_against_dop853(), "",
                      f"A filter's field against a degree-{TRUTH_DEGREE} truth (DRO + 100 km polar orbit, range + "
                      "range-rate every 60 s, 2 d, 8 runs, every default):", "", *filter_study()]) + "\n"
    args.output.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
