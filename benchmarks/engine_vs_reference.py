"""Seconds per 10-day EKF run: liaison's compiled engine vs a plain reference, same process, same inputs.

The reference is the obvious implementation, written here only as a yardstick: scipy solve_ivp
(DOP853, rtol 1e-10, atol 1e-12) once per measurement interval on state + STM, numpy EKF update with
Joseph form, no vectorisation, no JIT. Both filters get identical initial estimates and noisy
measurements (drawn by liaison's seeding), so their RMS errors must agree as well.

    python -m benchmarks.engine_vs_reference [--scenario scenarios/eml2_lunar.yaml] [--days 10]
"""

import argparse
import time

import numpy as np

from benchmarks.reference import reference_ekf
from liaison_cli.analysis.metrics import summary_rows
from liaison_cli.scenario.setup import prepare_problem
from liaison_cli.dynamics.constants import M_PER_LU, M_S_PER_VU
from liaison_cli.scenario.loading import apply_overrides, load_scenario
from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.estimation.estimators import estimate


def measure(scenario_path="scenarios/eml2_lunar.yaml", days=10.0, engine_runs=20, reference_runs=1,
            verbose=True) -> dict:
    """Median seconds per run of the engine and of the plain reference on identical inputs, plus the
    engine's first call (cache load, or compilation on a cold cache) and the scenario's epoch count."""
    scenario, _ = load_scenario(scenario_path)
    problem = prepare_problem(apply_overrides(scenario, {"duration_days": days}))

    def engine(inputs):
        return estimate("ekf", problem.filter, inputs.x0_hat, inputs.y_obs, inputs.truth)

    t0 = time.perf_counter()
    engine(draw_run_inputs(problem, 0))
    first_call = time.perf_counter() - t0  # cache load, or compile if the cache is cold

    engine_times, ref_times = [], []
    for run in range(engine_runs):
        inputs = draw_run_inputs(problem, run)
        t0 = time.perf_counter()
        out = engine(inputs)
        engine_times.append(time.perf_counter() - t0)
        if run < reference_runs:
            t0 = time.perf_counter()
            ref_err, ref_sig = reference_ekf(problem, inputs.x0_hat, inputs.y_obs)
            ref_times.append(time.perf_counter() - t0)
            fast = summary_rows(problem.times_s, out.err, out.sigma, problem.spacecraft, M_PER_LU, M_S_PER_VU)[0]
            ref = summary_rows(problem.times_s, ref_err, ref_sig, problem.spacecraft, M_PER_LU, M_S_PER_VU)[0]
            for a, b in zip(fast, ref):
                if verbose:
                    print(f"run {run} {a['spacecraft']:>6}: RMS position engine {a['rms_position_m']:.3f} m, "
                          f"reference {b['rms_position_m']:.3f} m; velocity {1e3 * a['rms_velocity_m_s']:.4f} / "
                          f"{1e3 * b['rms_velocity_m_s']:.4f} mm/s")
    return {"scenario": scenario.name, "epochs": problem.n_steps - 1, "first_call_s": first_call,
            "engine_s": float(np.median(engine_times)), "engine_runs": len(engine_times),
            "reference_s": float(np.median(ref_times)), "reference_runs": len(ref_times)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/eml2_lunar.yaml")
    parser.add_argument("--days", type=float, default=10.0)
    parser.add_argument("--reference-runs", type=int, default=1)
    parser.add_argument("--engine-runs", type=int, default=20)
    args = parser.parse_args()
    row = measure(args.scenario, args.days, args.engine_runs, args.reference_runs)
    print(f"scenario {row['scenario']}, {args.days:g} d, {row['epochs']} measurement epochs")
    print(f"engine first call (cache load or compile): {row['first_call_s']:.2f} s")
    print(f"engine:    {1e3 * row['engine_s']:8.1f} ms per run (median of {row['engine_runs']})")
    print(f"reference: {1e3 * row['reference_s']:8.1f} ms per run (median of {row['reference_runs']})")
    print(f"speed-up:  {row['reference_s'] / row['engine_s']:8.1f}x")


if __name__ == "__main__":
    main()
