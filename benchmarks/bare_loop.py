"""Per-run time of liaison's EKF against a bare compiled EKF loop, same session, same inputs (issue 37 item 4).

The bare loop is the smallest compiled EKF on the engine's inputs: per interval, each spacecraft's state and
STM, P <- Phi P Phi' + Q by blocks, a scalar geometric-range update in Joseph form, element loops, and only
the estimate recorded (no sigma, NEES, residuals or direction records). It runs with the scheme the engine
had before (state + STM by `rk4_substeps` RK4 steps of all 42 equations: rk4_variational_into), which is the
yardstick, and with the engine's own step (the STM on a coarser grid than the state: rk4_state_stm_into),
which separates what the algorithm saves from what the engine's records cost. liaison's engine is
`estimate("ekf", ...)` on the scenario's arrays, with everything it records. All take the same initial
estimates and noisy measurements, so their errors must agree.

`--accuracy` (any CRTBP EKF scenario) measures the coarser STM instead:
- Phi over each interval against DOP853 at rtol 1e-13 (relative to Phi's largest entry), for every step and
  for the engine's step;
- the budget that error must stay within: how much Phi changes when the state it is evaluated at moves by
  `--sigma-m` (m per axis, one value per estimated spacecraft, the last repeated; a settled 1-sigma): the EKF
  evaluates Phi at its estimate, not at the truth.

    python -m benchmarks.bare_loop [--scenario scenarios/eml2_lunar.yaml] [--runs 20] [--repeats 5]
    python -m benchmarks.bare_loop --accuracy --scenario scenarios/c5_star_eml2_nrho.yaml --sigma-m 300,1000,20
"""

import argparse
import time

import numpy as np
from numba import njit

from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import M_PER_LU
from liaison_cli.dynamics.crtbp import state_stm_derivative
from liaison_cli.dynamics.integrators.rk4 import (rk4_state_stm, rk4_state_stm_into, rk4_variational,
                                                  rk4_variational_into)
from liaison_cli.estimation.estimators import estimate
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.setup import prepare_problem


@njit(cache=True)
def bare_ekf(x0, P0, Q, ranges, sigma, dt, substeps, params, coarse):
    """Estimates (m, 12) of two spacecraft from crosslink ranges (m,) (NaN: none): the bare loop, its STM by
    every substep (coarse False) or on the engine's coarser grid (True). Element loops, no allocation per
    epoch; P <- Phi P Phi' + Q by 6 x 6 blocks (Phi is block-diagonal); Joseph update."""
    m, n = ranges.shape[0], x0.shape[0]
    x, P = x0.copy(), P0.copy()
    out = np.empty((m, n))
    out[0] = x
    y, work = np.empty(42), np.empty((5, 42))
    phi = np.zeros((2, 6, 6))
    half = np.empty((n, n))
    H, PH, K = np.zeros(n), np.empty(n), np.empty(n)
    A, AP = np.empty((n, n)), np.empty((n, n))
    state = np.empty(6)
    for k in range(1, m):
        for s in range(2):
            for i in range(6):
                state[i] = x[6 * s + i]
            if coarse:
                rk4_state_stm_into(state, dt, substeps, params, y, work)
            else:
                rk4_variational_into(state, dt, substeps, params, y, work)
            for i in range(6):
                x[6 * s + i] = y[i]
                for j in range(6):
                    phi[s, i, j] = y[6 + 6 * i + j]
        for i in range(n):  # half = Phi P
            a = i // 6
            for j in range(n):
                acc = 0.0
                for l in range(6):
                    acc += phi[a, i - 6 * a, l] * P[6 * a + l, j]
                half[i, j] = acc
        for i in range(n):  # P = half Phi' + Q
            for j in range(n):
                b = j // 6
                acc = Q[i, j]
                for l in range(6):
                    acc += half[i, 6 * b + l] * phi[b, j - 6 * b, l]
                P[i, j] = acc
        if np.isfinite(ranges[k]):
            rho2 = 0.0
            for i in range(3):
                rho2 += (x[i] - x[6 + i]) ** 2
            rho = np.sqrt(rho2)
            for i in range(3):
                H[i] = (x[i] - x[6 + i]) / rho
                H[6 + i] = -H[i]
            for i in range(n):
                acc = 0.0
                for j in range(n):
                    acc += P[i, j] * H[j]
                PH[i] = acc
            innovation_var = sigma * sigma
            for i in range(n):
                innovation_var += H[i] * PH[i]
            residual = ranges[k] - rho
            for i in range(n):
                K[i] = PH[i] / innovation_var
                x[i] += K[i] * residual
            for i in range(n):  # Joseph form: (I - K H) P (I - K H)' + K sigma^2 K'
                for j in range(n):
                    A[i, j] = (1.0 if i == j else 0.0) - K[i] * H[j]
            for i in range(n):
                for j in range(n):
                    acc = 0.0
                    for l in range(n):
                        acc += A[i, l] * P[l, j]
                    AP[i, j] = acc
            for i in range(n):
                for j in range(n):
                    acc = sigma * sigma * K[i] * K[j]
                    for l in range(n):
                        acc += AP[i, l] * A[j, l]
                    P[i, j] = acc
        for i in range(n):
            out[k, i] = x[i]
    return out


def _median_seconds(fn, runs_inputs, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for inputs in runs_inputs:
            fn(inputs)
        times.append((time.perf_counter() - t0) / len(runs_inputs))
    return float(np.median(times)), times


def stm_accuracy(problem, samples: int = 96, sigma_m=(300.0, 20.0)) -> dict:
    """Largest relative Phi error against DOP853 rtol 1e-13 over `samples` intervals of the truth, with every
    substep and with the engine's step; the budget: the smallest relative change of Phi when the state moves
    by sigma_m (m) per axis (one value per estimated spacecraft, the last repeated); and the largest ratio,
    interval by interval, of the engine's error to that change."""
    from scipy.integrate import solve_ivp

    f = problem.filter
    # eml2_lunar names rk4_substeps, so every spacecraft block takes the same count (FilterArrays.substeps: one
    # per block)
    mu, dt, substeps = float(f.model_params[0]), f.dt_tu, int(f.substeps[0])
    rng = np.random.default_rng(0)
    worst = {"every": 0.0, "engine": 0.0, "budget": np.inf, "share": 0.0}
    for k in np.linspace(0, problem.truth.shape[0] - 2, samples).astype(int):
        for s in range(problem.truth.shape[1] // 6):
            sigma = sigma_m[min(s, len(sigma_m) - 1)]
            state = problem.truth[k, 6 * s : 6 * s + 6]
            y0 = np.concatenate([state, np.eye(6).ravel()])
            ref = solve_ivp(lambda t, v: state_stm_derivative(v, mu), (0.0, dt), y0, method="DOP853", rtol=1e-13,
                            atol=1e-16).y[6:, -1]
            scale = np.abs(ref).max()
            every = rk4_variational(state.copy(), dt, substeps, np.array([mu]))[1].ravel()
            worst["every"] = max(worst["every"], np.abs(every - ref).max() / scale)
            engine_phi = rk4_state_stm(state.copy(), dt, substeps, np.array([mu]))[1].ravel()
            worst["engine"] = max(worst["engine"], np.abs(engine_phi - ref).max() / scale)
            moved = state.copy()
            moved[:3] += rng.normal(0.0, sigma / M_PER_LU, 3)
            shifted = rk4_state_stm(moved, dt, substeps, np.array([mu]))[1].ravel()
            budget = np.abs(shifted - engine_phi).max() / scale
            worst["budget"] = min(worst["budget"], budget)
            worst["share"] = max(worst["share"], (np.abs(engine_phi - ref).max() / scale) / budget)
    return worst


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/eml2_lunar.yaml")
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--accuracy", action="store_true", help="the coarser STM's accuracy only")
    parser.add_argument("--sigma-m", default="300,20", help="settled 1-sigma per spacecraft (m), comma list")
    args = parser.parse_args(argv)
    problem = prepare_problem(load_scenario(args.scenario)[0])
    sigma_m = tuple(float(v) for v in args.sigma_m.split(","))
    if args.accuracy:
        _print_accuracy(args.scenario, problem, sigma_m)
        return
    f = problem.filter
    if f.layout.n != 12 or f.channel_kind.shape[0] != 1:
        raise SystemExit(f"{args.scenario}: the bare loop takes two spacecraft and one crosslink range "
                         "(--accuracy takes any CRTBP EKF scenario)")
    mu, sigma = float(f.model_params[0]), float(f.sigma[0])
    inputs = [draw_run_inputs(problem, run) for run in range(args.runs)]
    runners = {
        "engine": lambda i: estimate("ekf", f, i.x0_hat, i.y_obs, i.truth),
        "bare loop": lambda i: bare_ekf(i.x0_hat, f.P0, f.Q, np.ascontiguousarray(i.y_obs[:, 0]), sigma, f.dt_tu,
                                        int(f.substeps[0]), np.array([mu]), False),
        "bare loop, coarse STM": lambda i: bare_ekf(i.x0_hat, f.P0, f.Q, np.ascontiguousarray(i.y_obs[:, 0]),
                                                    sigma, f.dt_tu, int(f.substeps[0]), np.array([mu]), True),
    }
    for run in runners.values():
        run(inputs[0])  # compile or load first
    seconds = {name: [] for name in runners}
    for _ in range(args.repeats):  # interleaved, so load changes hit all alike
        for name, run in runners.items():
            seconds[name].append(_median_seconds(run, inputs, 1)[0])
    median = {name: float(np.median(values)) for name, values in seconds.items()}
    final = {"engine": [runners["engine"](i).err[-1, :3] for i in inputs]}
    for name in ("bare loop", "bare loop, coarse STM"):
        final[name] = [runners[name](i)[-1, :3] - i.truth[-1, :3] for i in inputs]
    print(f"{args.scenario}: {args.runs} runs x {args.repeats} repeats, interleaved")
    for name, value in median.items():
        rms = np.sqrt(np.mean([(e**2).sum() for e in final[name]])) * M_PER_LU
        print(f"  {name:<22} {1e3 * value:6.2f} ms per run ({value / median['bare loop']:.3f} x the bare loop); "
              f"final first-spacecraft position RMS {rms:.1f} m")
    _print_accuracy(args.scenario, problem, sigma_m)


def _print_accuracy(label, problem, sigma_m):
    accuracy = stm_accuracy(problem, sigma_m=sigma_m)
    print(f"  {label}: Phi vs DOP853 rtol 1e-13 (largest relative error): every substep {accuracy['every']:.1e}, "
          f"the engine's step {accuracy['engine']:.1e}; Phi's change over a move of the state by "
          f"{', '.join(f'{v:g}' for v in sigma_m)} m (the EKF's own linearisation, smallest over the samples): "
          f"{accuracy['budget']:.1e}; the engine's error is at most {accuracy['share']:.2g} of that change, "
          f"interval by interval")


if __name__ == "__main__":
    main()
