"""The Moon's field in the dated model, measured: writes results/reference/lunar_field_dated.md.

`python -m benchmarks.lunar_field_dated` reports:
- the frame's weight: the dated model turns GRGM1200A with the IAU model of the Moon (the mean-Earth axes) and
  DE430's constant turn from those to the principal axes (dynamics.lunar_orientation). The IAU series is a fit to
  an older ephemeris's librations; its departure from DE421's integrated ones is benchmarks.lunar_orientation's
  (at most 18″ over 2000-2049). What is measured here is what a turn of that kind costs: the RMS change of the field's
  acceleration (degree 100, over a sphere at 100 km and 1,000 km) when it is turned by the mean-Earth to
  principal-axes angle (104 arcsec), against the field's own RMS; and the CRTBP's frame approximation's size for
  comparison (benchmarks.lunar_field: turned by 7.9 deg in longitude);
- the cost of the orientation (one rotation matrix) against one field evaluation with its gradient at degree 20;
- the truth against the filter's propagation: a 100 km polar orbit in DE421 + GRGM1200A to degree 100 over one day,
  the filter's RK8 at 15 s steps chained per 60 s interval against the truth's DOP853 (rtol 1e-13, flown about
  the Moon as the dated truth flies a lunar orbiter), and that truth against itself at rtol 3e-14; DOP853 flown
  geocentric at the tolerances every dated truth had before (rtol 1e-12, atol 1e-9) against itself at 1e-13;
- a dated formation: the Gateway's NRHO relay and a 100 km polar orbiter (range + range-rate every 60 s, 2.21 m,
  11 mm/s, 2 days from 2026-01-01, every filter default) under a degree-50 truth, the filter at degree 50 and 20:
  position error RMS after day 1, err/σ, the verdict, the default process noise and the time per run.
"""

import argparse
import time
from datetime import datetime
from pathlib import Path

import numpy as np

from benchmarks.lunar_field import MOON_RADIUS_KM, accelerations, rms, rotation, settled_figures, sphere, turned
from liaison_cli.dynamics.lunar_gravity import lunar_field
from liaison_cli.dynamics.lunar_orientation import PA_FROM_ME

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "lunar_field_dated.md"
EPOCH = datetime(2026, 1, 1)


def frame_weight(degree: int = 100, points_count: int = 2000) -> list[str]:
    field = lunar_field(degree)
    offset_arcsec = np.degrees(np.arccos((np.trace(PA_FROM_ME) - 1.0) / 2.0)) * 3600.0
    lines = [f"| altitude km | field RMS m/s² | turned {offset_arcsec:.0f}″ (mean-Earth to principal axes) | "
             "turned 7.9° in longitude (the CRTBP's frame) |", "|---|---|---|---|"]
    for altitude in (100.0, 1000.0):
        points = sphere(points_count, MOON_RADIUS_KM + altitude)
        base = accelerations(field, degree, points)
        small = turned(field, degree, points, PA_FROM_ME.T)
        large = turned(field, degree, points, rotation(2, 7.9))
        small_share, large_share = 100 * rms(small - base) / rms(base), 100 * rms(large - base) / rms(base)
        lines.append(f"| {altitude:.0f} | {rms(base):.3g} | {rms(small - base):.3g} ({small_share:.1f} %) "
                     f"| {rms(large - base):.3g} ({large_share:.0f} %) |")
    return lines


def orientation_cost(calls: int = 20000) -> str:
    from liaison_cli.dynamics.lunar_orientation import moon_pa_from_icrf_into
    from benchmarks.lunar_field import cost_us

    out = np.empty((3, 3))
    moon_pa_from_icrf_into(8.2e8, out)
    start = time.perf_counter()
    for k in range(calls):
        moon_pa_from_icrf_into(8.2e8 + k, out)
    rotation_us = (time.perf_counter() - start) / calls * 1e6
    field_us = cost_us(lunar_field(20), 20, True)
    return (f"The orientation costs {rotation_us:.2f} µs per call (one rotation matrix: the IAU series' 13 "
            f"arguments), against {field_us:.1f} µs for the degree-20 field with its gradient in the same session.")


def _model(degree: int, filter_degree: int | None = None):
    from liaison_cli.dynamics.ephemeris import GM_KM3_S2, load_window
    from liaison_cli.dynamics.ephemeris_dynamics import dated_terms, moon_harmonics_term
    from liaison_cli.dynamics.ephemeris_model import EphemerisDynamicsModel
    from liaison_cli.dynamics.timescales import utc_to_tdb_seconds
    from liaison_cli.scenario.dated import THIRD_BODIES

    t0 = utc_to_tdb_seconds(EPOCH)
    window = load_window(t0, t0 + 2 * 86400.0)
    bodies = np.array(THIRD_BODIES, dtype=np.int64)
    gms = np.array([GM_KM3_S2[int(b)] for b in bodies])
    own = None if filter_degree is None else dated_terms(moon_harmonics_term(lunar_field(filter_degree)))
    return EphemerisDynamicsModel(window, bodies, gms, GM_KM3_S2[399], 0.0, t0,
                                  terms=dated_terms(moon_harmonics_term(lunar_field(degree))), filter_terms=own)


def truth_against_filter(degree: int = 100) -> list[str]:
    from types import SimpleNamespace

    from liaison_cli.dynamics.constants import TU_S
    from liaison_cli.dynamics.ephemeris_dynamics import dop853_ephemeris_states
    from liaison_cli.dynamics.ephemeris_model import SCALE, ephemeris_state_stm_scaled
    from liaison_cli.scenario.dated import lunar_orbiter_state_km

    model = _model(degree)
    elements = SimpleNamespace(semi_major_axis_km=MOON_RADIUS_KM + 100.0, eccentricity=0.0, inclination_deg=90.0,
                               raan_deg=30.0, argument_of_perilune_deg=0.0, ta_deg=0.0)
    state_km = lunar_orbiter_state_km(elements, model)
    times_s = model.epoch_tdb_s + np.arange(0.0, 86400.0 + 1.0, 60.0)
    args = (state_km, times_s[0], times_s, model.window, model.bodies, model.gms, model.gm_earth, 0.0)
    geocentric = dop853_ephemeris_states(*args, rtol=1e-12, atol=1e-9, terms=model.terms)
    geocentric_tighter = dop853_ephemeris_states(*args, rtol=1e-13, atol=1e-9, terms=model.terms)
    start = time.perf_counter()
    truth = dop853_ephemeris_states(*args, terms=model.terms, moon_centred=True)
    truth_s = time.perf_counter() - start
    tighter = dop853_ephemeris_states(*args, rtol=3e-14, atol=3e-14, terms=model.terms, moon_centred=True)
    state, worst_m = state_km / SCALE, 0.0
    start = time.perf_counter()
    for k in range(1, len(times_s)):
        state, _ = ephemeris_state_stm_scaled(model.params, state, (times_s[k - 1] - times_s[0]) / TU_S,
                                              60.0 / TU_S, 4)
        worst_m = max(worst_m, float(np.linalg.norm(state[:3] * SCALE[:3] - truth[k, :3])) * 1e3)
    filter_s = time.perf_counter() - start
    def apart_m(a, b):
        return float(np.max(np.linalg.norm(a[:, :3] - b[:, :3], axis=1))) * 1e3

    return [f"A 100 km polar orbit over one day in DE421 + GRGM1200A to degree {degree}: the filter's RK8 (15 s steps, "
            f"with its STM, chained per 60 s interval) is {worst_m:.3g} m from the truth's DOP853 (rtol 1e-13, "
            f"flown about the Moon) at worst, and that truth {apart_m(truth, tighter):.3g} m from itself at rtol "
            f"3e-14 ({filter_s:.1f} s and {truth_s:.1f} s). Flown geocentric at the dated truth's earlier tolerances, "
            f"DOP853 at rtol 1e-12 (atol 1e-9) is {apart_m(geocentric, geocentric_tighter):.3g} m from itself at 1e-13 and "
            f"{apart_m(geocentric, truth):.3g} m from the truth flown about the Moon."]


def formation_study(runs: int = 6) -> list[str]:
    from liaison_cli.campaign.engine.results import summary_table
    from liaison_cli.campaign.engine.runner import run_campaign
    from liaison_cli.scenario.loading import validate_scenario

    lines = ["| filter degree | spacecraft | pos RMS after day 1, m | err/σ | own NEES in band | verdict | "
             "default q, m²/s³ | s per run |", "|---|---|---|---|---|---|---|---|"]
    for degree in (50, 20):
        mapping = {"name": f"dated_relay_{degree}", "duration_days": 2.0, "dynamics": "ephemeris",
                   "ephemeris": {"epoch_utc": EPOCH.isoformat(), "cr": 1.3, "area_to_mass_m2_kg": 0.01},
                   "spacecraft": [{"name": "Relay", "orbit": "nrho_gateway"},
                                  {"name": "User", "orbit": "lunar_keplerian",
                                   "elements": {"altitude_km": 100.0, "e": 0.0, "i_deg": 90.0, "raan_deg": 30.0}}],
                   "links": [{"receiver": "Relay", "transponder": "User", "observables": ["range", "range_rate"],
                              "occultation": True}],
                   "measurement": {"interval_s": 60, "light_time": False},
                   "noise": {"sigma_m": 2.21, "range_rate_sigma_m_s": 0.011},
                   "moon_gravity": {"degree": 50, "filter_degree": degree}, "monte_carlo": {"runs": runs, "seed": 46}}
        scenario = validate_scenario(mapping, mapping["name"])
        start = time.perf_counter()
        result = run_campaign(scenario, jobs=2, progress=False)
        per_run_s = (time.perf_counter() - start) / runs
        noises = result.problem.default_noises  # as the campaign flew it: the rule, LinCov-checked
        summary = summary_table(result)
        for name, rms_m, ratio, halfwidth, in_band, consistent in settled_figures(summary):
            verdict = "consistent" if consistent else "not consistent"
            lines.append(f"| {degree} | {name} | {rms_m:.3g} | {ratio:.2f} ± {halfwidth:.2f} | {100 * in_band:.0f} % "
                         f"| {verdict} | {noises[name].psd_m2_s3:.2g} | {per_run_s:.1f} |")
    return lines


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=6)
    args = parser.parse_args(argv)
    parts = [f"Written by `python -m benchmarks.lunar_field_dated --runs {args.runs}`; do not edit by hand. The "
             "Moon's field in the dated model (DE421 + GRGM1200A, the Moon turned by the IAU model and DE430's "
             "principal axes).", "", "The frame's weight (degree 100, 2,000 points on each sphere):", "",
             *frame_weight(), "", orientation_cost(), "", *truth_against_filter(), "",
             f"A dated formation (NRHO relay + 100 km polar orbiter from {EPOCH:%Y-%m-%d}, range + range-rate every "
             f"60 s at 2.21 m and 11 mm/s, 2 d, {args.runs} runs, truth degree 50, every filter default; statistics "
             "after day 1; s per run: wall time of the campaign on 2 cores over the runs):", "",
             *formation_study(args.runs)]
    OUTPUT.write_text("\n".join(parts) + "\n")
    print(OUTPUT.read_text())


if __name__ == "__main__":
    main()
