"""The CCSDS round-trip figures of docs/exchange.md, on the full spans of eph_eml1_eml2_dsn and eml2_lunar.

For each scenario: run 2 runs, export run 1 (OEM truth + estimate with covariance, TDM; KVN and XML), then
- read every file back with ccsds-ndm: largest difference from the recomputed run (km, km/s, km^2...);
- feed the TDM back (measurements: {tdm, run: 1}): largest difference of the estimate (m, m/s);
- dated only: the truth OEMs as orbit: {oem} on the same grid (truth and estimate differences), and on a grid
  of half the interval (every other epoch falls between two OEM lines: Lagrange-7 interpolation against the
  truth propagated again from its initial state to those epochs).

Run from the repository root:  python -m benchmarks.exchange_round_trip [OUT_DIR]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

from liaison_cli.campaign.exchange.export import KM_PER_SCALED, export_run, recompute_run
from liaison_cli.campaign.engine.results import stream_campaign
from liaison_cli.dynamics.constants import TU_S
from liaison_cli.exchange.oem import read_oem
from liaison_cli.scenario.loading import apply_overrides, load_scenario, validate_scenario
from liaison_cli.scenario.setup import prepare_problem

RUN = 1
M = np.array([1e3] * 6)  # km -> m, km/s -> m/s


def _largest(a, b) -> tuple[float, float]:
    """Largest position (m) and velocity (m/s) difference of two (m, 6 n) scaled state histories."""
    d = (np.abs(a - b).reshape(len(a), -1, 6) * KM_PER_SCALED * M).max(axis=(0, 1))
    return float(d[:3].max()), float(d[3:].max())


def _with(scenario, **changes):
    data = scenario.model_dump(mode="json", exclude={"topology"})
    for key, value in changes.items():
        data[key] = value
    return validate_scenario(data)


def measure(name: str, root: Path) -> None:
    scenario, text = load_scenario(Path("scenarios") / f"{name}.yaml")
    result = root / name
    stream_campaign(scenario, result, text, runs=2, jobs=1, progress=False)
    folder = result / "ccsds"
    folder.mkdir()
    done = export_run(result, RUN, ("kvn", "xml"), folder)
    print(f"{name}: {done['epochs']} epochs, {len(done['files'])} files, recomputed run within "
          f"{done['stored_difference_m']:.2g} m of the stored position errors")
    problem = prepare_problem(scenario)
    original = recompute_run(problem, RUN)
    worst = 0.0
    for i, sc in enumerate(problem.spacecraft):
        block = slice(6 * i, 6 * i + 6)
        for stem, states in (("truth", original.truth), ("estimate", original.estimate)):
            for suffix in ("", ".xml"):
                (eph,) = read_oem(folder / f"{sc}_{stem}.oem{suffix}")
                worst = max(worst, float(np.abs(eph.states_km - states[:, block] * KM_PER_SCALED).max()))
    print(f"  OEM read back (KVN, XML): largest state difference {worst:.3g} km")
    for suffix in ("", ".xml"):
        fed = recompute_run(prepare_problem(_with(scenario, measurements={
            "tdm": str(folder / f"measurements.tdm{suffix}"), "run": RUN})), 0)
        position_m, velocity_m_s = _largest(fed.estimate, original.estimate)
        print(f"  TDM{suffix or ' (KVN)'} fed back: estimate within {position_m:.3g} m, {velocity_m_s:.3g} m/s")
    if scenario.dynamics != "ephemeris":
        return
    spacecraft = scenario.model_dump(mode="json")["spacecraft"]
    for sc in spacecraft:
        sc.pop("orbit_file", None)
        sc["orbit"] = {"oem": str(folder / f"{sc['name']}_truth.oem")}
    imported = _with(scenario, spacecraft=spacecraft)
    problem_oem = prepare_problem(imported)
    print("  truth from its OEM, same grid: within %.3g m, %.3g m/s" % _largest(problem_oem.truth, problem.truth))
    again = recompute_run(problem_oem, RUN)
    print("  estimate on that truth: within %.3g m, %.3g m/s" % _largest(again.estimate, original.estimate))
    half = scenario.measurement.interval_s / 2
    measurement = {**scenario.measurement.model_dump(mode="json"), "interval_s": half}
    span_days = float(problem.times_s[-1]) / 86400.0  # the OEM ends at the last epoch of the coarse grid
    fine = prepare_problem(_with(imported, measurement=measurement, duration_days=span_days))
    fine_oem = fine.truth
    # The reference: each spacecraft's truth propagated again from its initial state to the fine epochs.
    fine_tu = fine.times_s / TU_S
    fine_truth = np.hstack([problem.dynamics.truth_states(problem.truth[0, 6 * i: 6 * i + 6], fine_tu)
                            for i in range(problem.n_spacecraft)])
    between = slice(1, None, 2)
    print("  truth from its OEM between lines (Lagrange 7, %g s from a line): within %.3g m, %.3g m/s"
          % (half, *_largest(fine_oem[between], fine_truth[between])))


def main() -> None:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="exchange-"))
    for name in ("eph_eml1_eml2_dsn", "eml2_lunar"):
        measure(name, root)


if __name__ == "__main__":
    main()
