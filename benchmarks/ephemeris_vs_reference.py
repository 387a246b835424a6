"""Seconds per 9-day dated EKF run (003): liaison's compiled engine vs a plain reference, same inputs.

The reference is the obvious implementation, written here only as a yardstick: scipy solve_ivp (DOP853,
rtol 1e-10, atol 1e-9 km) once per measurement interval on state + STM, with the Moon's and the Sun's
positions from jplephem's own `compute` at every right-hand-side call, point masses of the Earth, Moon
and Sun plus cannonball SRP with its own conical shadow of the Earth and the Moon, numpy range /
range-rate partials and the same underweighted Joseph update. Its model is the filter's (Earth, Moon,
Sun; the run's drawn C_R), so both filters must give the same errors to a small fraction of the RMS.

    python -m benchmarks.ephemeris_vs_reference [--scenario scenarios/003/cassini.yaml] [--runs 10]
"""

import argparse
import time

import numpy as np
from scipy.integrate import solve_ivp

from liaison_cli.campaign.engine.worker import draw_run_inputs
from liaison_cli.dynamics.constants import M_PER_LU, TU_S
from liaison_cli.dynamics.ephemeris import GM_KM3_S2, J2000_JD, SECONDS_PER_DAY, de421_path
from liaison_cli.dynamics.ephemeris_dynamics import AU_KM, P_1AU_N_M2, R_EARTH_KM, R_MOON_KM, R_SUN_KM
from liaison_cli.dynamics.ephemeris_model import PARAM_CR_AM, SCALE
from liaison_cli.estimation.estimators import estimate
from liaison_cli.measurements.range import KIND_RANGE
from liaison_cli.measurements.range_rate import KIND_RANGE_RATE
from liaison_cli.scenario.loading import load_scenario
from liaison_cli.scenario.setup import prepare_problem


class PlainSky:
    """Geocentric Moon and Sun (km) at TDB seconds past J2000, straight from jplephem."""

    def __init__(self):
        from jplephem.spk import SPK

        self.kernel = SPK.open(de421_path())

    def moon_sun(self, t_s):
        jd = J2000_JD + t_s / SECONDS_PER_DAY
        k = self.kernel
        earth = k[3, 399].compute(jd)
        moon = k[3, 301].compute(jd) - earth
        sun = k[0, 10].compute(jd) - k[0, 3].compute(jd) - earth
        return moon, sun


def _sunlit_fraction(r, sun, body, radius_body_km):
    """Conical shadow: the share of the solar disc seen from r past one occulting sphere."""
    to_sun, to_body = sun - r, body - r
    a = np.arcsin(R_SUN_KM / np.linalg.norm(to_sun))
    b = np.arcsin(radius_body_km / np.linalg.norm(to_body))
    c = np.arccos(np.clip(to_sun @ to_body / (np.linalg.norm(to_sun) * np.linalg.norm(to_body)), -1.0, 1.0))
    if c >= a + b:
        return 1.0
    if c <= b - a:
        return 0.0
    if c <= a - b:
        return 1.0 - (b / a) ** 2
    x = (c * c + a * a - b * b) / (2.0 * c)
    y = np.sqrt(max(a * a - x * x, 0.0))
    overlap = a * a * np.arccos(x / a) + b * b * np.arccos((c - x) / b) - c * y
    return 1.0 - overlap / (np.pi * a * a)


def _rhs(t_s, y, sky, cr_am):
    r = y[:3]
    moon, sun = sky.moon_sun(t_s)
    acc = -GM_KM3_S2[399] * r / np.linalg.norm(r) ** 3
    G = GM_KM3_S2[399] * (3.0 * np.outer(r, r) / np.linalg.norm(r) ** 5 - np.eye(3) / np.linalg.norm(r) ** 3)
    for r_b, gm in ((moon, GM_KM3_S2[301]), (sun, GM_KM3_S2[10])):
        d = r_b - r
        acc += gm * (d / np.linalg.norm(d) ** 3 - r_b / np.linalg.norm(r_b) ** 3)
        G += gm * (3.0 * np.outer(d, d) / np.linalg.norm(d) ** 5 - np.eye(3) / np.linalg.norm(d) ** 3)
    d = r - sun
    nu = _sunlit_fraction(r, sun, np.zeros(3), R_EARTH_KM) * _sunlit_fraction(r, sun, moon, R_MOON_KM)
    acc += nu * P_1AU_N_M2 * (AU_KM / np.linalg.norm(d)) ** 2 * cr_am * 1e-3 * d / np.linalg.norm(d)
    A = np.zeros((6, 6))
    A[:3, 3:] = np.eye(3)
    A[3:, :3] = G
    return np.concatenate([y[3:6], acc, (A @ y[6:].reshape(6, 6)).ravel()])


def _partials(kind, x_r, x_t):
    """Value and partials (w.r.t. receiver and transmitter states) of range / range-rate, scaled units."""
    d, dv = x_r[:3] - x_t[:3], x_r[3:] - x_t[3:]
    rho = np.linalg.norm(d)
    if kind == KIND_RANGE:
        g = np.concatenate([d / rho, np.zeros(3)])
        return rho, g, -g
    rate = d @ dv / rho
    g = np.concatenate([(dv - rate * d / rho) / rho, d / rho])
    return rate, g, -g


def reference_ekf(problem, inputs, sky):
    """Plain EKF over a dated problem; returns err (m, n) in scaled units like the engine."""
    f = problem.filter
    epoch_s = problem.dynamics.epoch_tdb_s
    cr_am = (inputs.filter_params if inputs.filter_params is not None else f.model_params)[PARAM_CR_AM]
    m, n = problem.truth.shape
    n_sc = n // 6
    D = np.diag(SCALE)
    x_hat, P = inputs.x0_hat[:n].copy(), f.P0[:n, :n].copy()
    err = np.full((m, n), np.nan)
    err[0] = x_hat - problem.truth[0]
    dt_s = f.dt_tu * TU_S
    for k in range(1, m):
        x_bar, Phi = np.empty(n), np.zeros((n, n))
        for s in range(n_sc):
            y0 = np.concatenate([x_hat[6 * s : 6 * s + 6] * SCALE, np.eye(6).ravel()])
            t0 = epoch_s + (k - 1) * dt_s
            sol = solve_ivp(_rhs, (t0, t0 + dt_s), y0, method="DOP853", rtol=1e-10, atol=1e-9, args=(sky, cr_am))
            x_bar[6 * s : 6 * s + 6] = sol.y[:6, -1] / SCALE
            Phi[6 * s : 6 * s + 6, 6 * s : 6 * s + 6] = np.linalg.inv(D) @ sol.y[6:, -1].reshape(6, 6) @ D
        P = Phi @ P @ Phi.T + f.Q[:n, :n]
        dx = np.zeros(n)
        for c in range(len(f.channel_kind)):
            if not np.isfinite(inputs.y_obs[k, c]):
                continue
            ra, rk, ta, tk = f.channel_ends[c]
            x_r = x_bar[ra : ra + 6] if ra >= 0 else f.known_states[k, rk]
            x_t = x_bar[ta : ta + 6] if ta >= 0 else f.known_states[k, tk]
            value, g_r, g_t = _partials(f.channel_kind[c], x_r, x_t)
            H = np.zeros(n)
            if ra >= 0:
                H[ra : ra + 6] = g_r
            if ta >= 0:
                H[ta : ta + 6] = g_t
            R = f.sigma[c] ** 2
            hph = H @ P @ H
            K = P @ H / ((1.0 + f.underweight) * hph + R)
            dx = dx + K * (inputs.y_obs[k, c] - value - H @ dx)
            IKH = np.eye(n) - np.outer(K, H)
            P = IKH @ P @ IKH.T + R * np.outer(K, K)
        x_hat = x_bar + dx
        err[k] = x_hat - problem.truth[k]
    return err


def measure(scenario_path="scenarios/003/cassini.yaml", runs=10, verbose=True) -> dict:
    scenario, _ = load_scenario(scenario_path)
    problem = prepare_problem(scenario)
    assert set(problem.filter.channel_kind) <= {KIND_RANGE, KIND_RANGE_RATE}
    n_dyn = 6 * problem.n_spacecraft

    def engine(inputs):
        arrays = problem.filter
        if inputs.filter_params is not None:
            from dataclasses import replace

            arrays = replace(arrays, model_params=inputs.filter_params)
        return estimate("ekf", arrays, inputs.x0_hat, inputs.y_obs, inputs.truth)

    t0 = time.perf_counter()
    engine(draw_run_inputs(problem, 0))
    first_call = time.perf_counter() - t0
    times = []
    for run in range(runs):
        inputs = draw_run_inputs(problem, run)
        t0 = time.perf_counter()
        out = engine(inputs)
        times.append(time.perf_counter() - t0)
    inputs = draw_run_inputs(problem, 0)
    sky = PlainSky()
    t0 = time.perf_counter()
    ref_err = reference_ekf(problem, inputs, sky)
    ref_s = time.perf_counter() - t0
    fast = engine(inputs).err[:, :n_dyn]
    late = problem.times_s >= SECONDS_PER_DAY
    rms = {}
    for label, e in (("engine", fast), ("reference", ref_err)):
        pos = e.reshape(len(e), -1, 6)[:, :, :3] * M_PER_LU
        rms[label] = np.sqrt(np.mean(np.sum(pos[late] ** 2, axis=2), axis=0))
    result = {"engine_s": float(np.median(times)), "first_call_s": first_call, "reference_s": ref_s,
              "epochs": len(problem.times_s), "rms_engine_m": rms["engine"], "rms_reference_m": rms["reference"],
              "spacecraft": problem.spacecraft}
    if verbose:
        print(f"{scenario.name}: {len(problem.times_s)} epochs, {n_dyn} states, {len(problem.channels)} channels")
        print(f"engine: {result['engine_s']:.3f} s per run (median of {runs}; first call {first_call:.2f} s)")
        print(f"plain reference: {ref_s:.1f} s per run; ratio {ref_s / result['engine_s']:.0f}x")
        for name, a, b in zip(problem.spacecraft, rms["engine"], rms["reference"]):
            print(f"  {name}: position RMS after day 1, engine {a:.2f} m, reference {b:.2f} m")
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="scenarios/003/cassini.yaml")
    parser.add_argument("--runs", type=int, default=10)
    args = parser.parse_args()
    measure(args.scenario, args.runs)


if __name__ == "__main__":
    main()
