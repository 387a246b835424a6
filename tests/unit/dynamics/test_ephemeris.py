"""003 item 1-2: DE421 read offline by our compiled Chebyshev code, time scales, and the dated dynamics
(point masses + SRP with conical shadows) with their STM; skyfield on the same file is the reference."""

import math
from datetime import datetime

import numpy as np
import pytest

from liaison_cli.dynamics.ephemeris import (GM_KM3_S2, J2000_JD, de421_path, geocentric_positions_into,
                                           geocentric_state, load_window)
from liaison_cli.dynamics.ephemeris_dynamics import (
    AU_KM,
    NO_TERMS,
    P_1AU_N_M2,
    R_EARTH_KM,
    dop853_ephemeris_states,
    srp_acceleration,
    visible_fraction,
)
from liaison_cli.dynamics.integrators.rk8 import RK8_A, RK8_B, RK8_C, rk8_advance_ephemeris
from liaison_cli.dynamics.timescales import utc_to_tdb_seconds, utc_to_tt_seconds

skyfield = pytest.importorskip("skyfield.api")

# 003 Table 1's departure dates (UTC): Cassini, MER-A, MSL.
MISSION_DATES = (datetime(1997, 10, 15, 8, 43), datetime(2003, 6, 10, 17, 58, 47), datetime(2011, 11, 26, 15, 2))
THIRD_BODIES = np.array([301, 10, 1, 2, 4, 5, 6, 7, 8, 9])


@pytest.fixture(scope="module")
def sky():
    return skyfield.load.timescale(builtin=True), skyfield.load_file(de421_path())


@pytest.mark.parametrize("date", MISSION_DATES)
def test_moon_and_sun_agree_with_skyfield_on_the_same_file(sky, date):
    """Geocentric Moon and Sun over 9 days from each mission date: within 1 m (measured: mm)."""
    ts, eph = sky
    t0 = utc_to_tdb_seconds(date)
    window = load_window(t0, t0 + 9 * 86400)
    worst = 0.0
    for t_s in np.linspace(t0, t0 + 9 * 86400, 40):
        t = ts.tdb_jd(J2000_JD, t_s / 86400.0)
        for body, name in ((301, "moon"), (10, "sun")):
            ours = geocentric_state(window.coeffs, window.start_s, window.interval_s, window.n_records, body, t_s)
            theirs = (eph[name] - eph["earth"]).at(t)
            worst = max(worst, np.linalg.norm(ours[:3] - theirs.position.km) * 1e3)
            assert np.linalg.norm(ours[3:] - theirs.velocity.km_per_s) < 1e-9
    assert worst < 1.0


@pytest.mark.parametrize("date", [*MISSION_DATES, datetime(2025, 3, 1)])
def test_time_scales_agree_with_skyfield(sky, date):
    ts, _ = sky
    t = ts.utc(date.year, date.month, date.day, date.hour, date.minute, date.second)
    assert utc_to_tt_seconds(date) == pytest.approx((t.whole - J2000_JD + t.tt_fraction) * 86400.0, abs=1e-6)
    assert utc_to_tdb_seconds(date) == pytest.approx((t.whole - J2000_JD + t.tdb_fraction) * 86400.0, abs=1e-5)  # measured 4.4 us: skyfield uses a shorter TDB - TT series


def test_dates_outside_de421_and_before_the_leap_table_are_refused():
    with pytest.raises(ValueError, match="DE421 covers"):
        load_window(utc_to_tdb_seconds(datetime(2060, 1, 1)), utc_to_tdb_seconds(datetime(2060, 1, 10)))
    with pytest.raises(ValueError, match="before 1972"):
        utc_to_tdb_seconds(datetime(1969, 7, 20))


def test_srp_matches_the_textbook_pressure_at_one_au():
    """P = 4.56e-6 N/m^2 at 1 AU; with C_R = 1.5 and A/m = 0.01 m^2/kg (003) the acceleration is
    1.5 x 0.01 x 4.56e-6 = 6.84e-8 m/s^2, pointing away from the Sun, and it falls as 1/d^2."""
    assert P_1AU_N_M2 == pytest.approx(4.56e-6, rel=1e-3)
    r_sun = np.array([AU_KM, 0.0, 0.0])
    out = np.empty(3)
    nu = srp_acceleration(np.array([0.0, 1.0e6, 0.0]), r_sun, np.array([0.0, -4e5, 0.0]), 0.015, out)
    assert nu == 1.0
    direction = (np.array([0.0, 1.0e6, 0.0]) - r_sun) / np.linalg.norm(np.array([0.0, 1.0e6, 0.0]) - r_sun)
    expected = 0.015 * P_1AU_N_M2 * 1e-3 * (AU_KM / np.linalg.norm(np.array([0.0, 1.0e6, 0.0]) - r_sun)) ** 2
    assert np.allclose(out, expected * direction, rtol=1e-12)
    assert np.linalg.norm(out) * 1e3 == pytest.approx(6.84e-8, rel=0.01)


def test_shadow_is_zero_in_umbra_one_in_sunlight_and_continuous_across_the_penumbra():
    r_sun = np.array([AU_KM, 0.0, 0.0])
    earth = np.zeros(3)
    assert visible_fraction(np.array([-10000.0, 0.0, 0.0]), r_sun, earth, R_EARTH_KM) == 0.0
    assert visible_fraction(np.array([10000.0, 0.0, 0.0]), r_sun, earth, R_EARTH_KM) == 1.0
    assert visible_fraction(np.array([-10000.0, 20000.0, 0.0]), r_sun, earth, R_EARTH_KM) == 1.0
    # Across the shadow's edge 40,000 km behind the Earth: monotone from 0 to 1, no jump.
    heights = np.linspace(5000.0, 8500.0, 20001)
    nu = np.array([visible_fraction(np.array([-40000.0, h, 0.0]), r_sun, earth, R_EARTH_KM) for h in heights])
    assert nu[0] == 0.0 and nu[-1] == 1.0
    assert np.all(np.diff(nu) >= -1e-12) and np.max(np.diff(nu)) < 1e-3
    assert 100 < np.count_nonzero((nu > 0) & (nu < 1)) < 20000  # a real penumbra, resolved


def _propagate(window, t0, x0, dt, n, gm_bodies=True, cr_am=0.015, stm=False):
    bodies = THIRD_BODIES if gm_bodies else np.zeros(0, dtype=np.int64)
    gms = np.array([GM_KM3_S2[int(b)] for b in bodies])
    y = np.zeros(42) if stm else x0.copy()
    if stm:
        y[:6] = x0
        y[6::7] = 1.0
    rk8_advance_ephemeris(y, t0, dt, n, window.coeffs, window.start_s, window.interval_s, window.n_records, bodies,
                          gms, GM_KM3_S2[399], cr_am, NO_TERMS, RK8_A, RK8_B, RK8_C)
    return y


@pytest.fixture(scope="module")
def msl_window():
    t0 = utc_to_tdb_seconds(MISSION_DATES[2])
    window = load_window(t0, t0 + 10 * 86400)
    moon = geocentric_state(window.coeffs, window.start_s, window.interval_s, window.n_records, 301, t0)
    return t0, window, np.concatenate([0.85 * moon[:3], 0.85 * moon[3:]])  # near EML1


def test_the_right_hand_sides_positions_are_geocentric_states_bit_for_bit(msl_window):
    """geocentric_positions_into (the dynamics' per-stage evaluation: the Earth's and the EMB's segments once, no
    velocities) gives geocentric_state's positions to the last bit for every third body, in any order, the Moon
    first, last or alone, across record boundaries and at the window's ends."""
    t0, w, _ = msl_window
    span = (t0, t0 + 10 * 86400)
    # beyond the window's padded records too (load_window adds 2 days): both clamp to the first or last record
    times = np.concatenate([np.linspace(span[0], span[1], 97), [span[0] + 1e-3, span[1] - 1e-3],
                            [span[0] - 5 * 86400, span[1] + 5 * 86400]])
    orders = (THIRD_BODIES, THIRD_BODIES[::-1], np.array([301]), np.array([10, 5]))
    work = np.empty((3, 3))
    for bodies in orders:
        out = np.empty((len(bodies), 3))
        for t in times:
            geocentric_positions_into(w.coeffs, w.start_s, w.interval_s, w.n_records, bodies, t, out, work)
            for k, body in enumerate(bodies):
                expected = geocentric_state(w.coeffs, w.start_s, w.interval_s, w.n_records, body, t)[:3]
                assert np.array_equal(out[k], expected), (body, t)


def test_ephemeris_stm_matches_central_differences(msl_window):
    t0, window, x0 = msl_window
    phi = _propagate(window, t0, x0, 86400.0, 100, stm=True)[6:].reshape(6, 6)
    numeric = np.empty((6, 6))
    for j in range(6):
        h = 1e-3 if j < 3 else 1e-6
        e = np.zeros(6)
        e[j] = h
        numeric[:, j] = (_propagate(window, t0, x0 + e, 86400.0, 100) - _propagate(window, t0, x0 - e, 86400.0, 100)) / (2 * h)
    assert np.max(np.abs(numeric - phi)) < 1e-6 * np.max(np.abs(phi))


def test_two_body_energy_is_conserved_and_the_steps_converge(msl_window):
    t0, window, x0 = msl_window
    end = _propagate(window, t0, x0, 9 * 86400.0, 900, gm_bodies=False, cr_am=0.0)

    def energy(x):
        return 0.5 * x[3:] @ x[3:] - GM_KM3_S2[399] / np.linalg.norm(x[:3])

    assert energy(end) == pytest.approx(energy(x0), rel=1e-12)
    # Without SRP the fixed-step RK8 has converged at 864 s steps (the field is smooth) ...
    coarse = _propagate(window, t0, x0, 9 * 86400.0, 900, cr_am=0.0)
    fine = _propagate(window, t0, x0, 9 * 86400.0, 1800, cr_am=0.0)
    assert np.linalg.norm(coarse[:3] - fine[:3]) < 1e-5  # km: 1 cm after 9 days
    assert math.isfinite(coarse[0])


def test_truth_resolves_the_eclipse_that_fixed_steps_smear(msl_window):
    """This path crosses a shadow: the fixed-step RK8 loses its order there (metres after 9 days); the
    adaptive truth restarted at each shadow edge (TRUTH_RTOL 1e-13) agrees with itself at rtol 3e-14 to 0.29 cm
    (OpenBLAS SkylakeX kernel), 0.67 cm (Sandybridge), 0.34 cm (Nehalem); tolerance 1.5 cm, twice the largest.
    The arc near EML1 is unstable (an e-fold in about 1.7 d), so each kernel's last bits grow over the 9 days:
    at the former rtol 1e-12 / atol 1e-9 the same comparison gave 29-69 cm. Without SRP the truth and a fine RK8 agree to 0.8-1.1 cm (tolerance 2.5 cm)."""
    t0, window, x0 = msl_window
    bodies = THIRD_BODIES
    gms = np.array([GM_KM3_S2[int(b)] for b in bodies])
    end = t0 + 9 * 86400.0
    truth = dop853_ephemeris_states(x0, t0, [t0, end], window, bodies, gms, GM_KM3_S2[399], 0.015)[-1]
    tighter = dop853_ephemeris_states(x0, t0, [t0, end], window, bodies, gms, GM_KM3_S2[399], 0.015,
                                      rtol=3e-14, atol=3e-14)[-1]
    assert np.linalg.norm(truth[:3] - tighter[:3]) < 1.5e-5
    fixed = _propagate(window, t0, x0, 9 * 86400.0, 900)
    assert np.linalg.norm(fixed[:3] - truth[:3]) > 1e-4  # the eclipse costs the fixed steps > 10 cm
    no_srp = dop853_ephemeris_states(x0, t0, [t0, end], window, bodies, gms, GM_KM3_S2[399], 0.0)[-1]
    assert np.linalg.norm(no_srp[:3] - _propagate(window, t0, x0, 9 * 86400.0, 1800, cr_am=0.0)[:3]) < 2.5e-5


def test_ephemeris_model_behind_the_dynamics_interface(msl_window):
    """MODEL_EPHEMERIS through dynamics.model.propagate_state_stm_into (compiled with the model code as a constant):
    the same state as the RK8 in km, in the estimators' scaled units, and an STM that matches central
    differences in those units."""
    from liaison_cli.dynamics.constants import LU_KM, TU_S, VU_KM_S
    from liaison_cli.dynamics.ephemeris_model import pack_params
    from liaison_cli.dynamics.model import MODEL_EPHEMERIS

    step = _state_stm_step()
    t0, window, x0 = msl_window
    gms = np.array([GM_KM3_S2[int(b)] for b in THIRD_BODIES])
    params = pack_params(window, THIRD_BODIES, gms, GM_KM3_S2[399], 0.015, t0)
    scale = np.array([LU_KM] * 3 + [VU_KM_S] * 3)
    x0_lu = x0 / scale
    dt_tu = 86400.0 / TU_S
    end_lu, phi = step(MODEL_EPHEMERIS, params, x0_lu, 0.0, dt_tu, 100)
    assert np.allclose(end_lu * scale, _propagate(window, t0, x0, 86400.0, 100), rtol=0, atol=1e-9)
    numeric = np.empty((6, 6))
    for j in range(6):
        e = np.zeros(6)
        e[j] = 1e-8
        numeric[:, j] = (step(MODEL_EPHEMERIS, params, x0_lu + e, 0.0, dt_tu, 100)[0]
                         - step(MODEL_EPHEMERIS, params, x0_lu - e, 0.0, dt_tu, 100)[0]) / 2e-8
    assert np.max(np.abs(numeric - phi)) < 1e-6 * np.max(np.abs(phi))


def test_cr_column_matches_central_differences(msl_window):
    """The estimated C_R's coupling column (dynamics.model.propagate_parameter_into): d state / d cr_scale
    over one day of the dated model with SRP against central differences of the propagated state in the
    correction (step 1e-4), in the estimators' scaled units; at cr_scale = 0.1 the state and STM are those of
    a model whose C_R A/m is 1.1 times larger, to the last bit."""
    import numba

    from liaison_cli.dynamics.constants import LU_KM, TU_S, VU_KM_S
    from liaison_cli.dynamics.ephemeris_model import pack_params
    from liaison_cli.dynamics.model import MODEL_EPHEMERIS, PROPAGATION_SIZE, propagate_parameter_into

    @numba.njit
    def step(model, params, cr_scale, state, t_tu, dt_tu, n):
        y = np.empty(PROPAGATION_SIZE)
        propagate_parameter_into(model, params, cr_scale, state, t_tu, dt_tu, n, y, np.empty((5, 42)))
        return y

    plain = _state_stm_step()
    t0, window, x0 = msl_window
    gms = np.array([GM_KM3_S2[int(b)] for b in THIRD_BODIES])
    x0_lu = x0 / np.array([LU_KM] * 3 + [VU_KM_S] * 3)
    dt_tu = 86400.0 / TU_S
    params = pack_params(window, THIRD_BODIES, gms, GM_KM3_S2[399], 0.015, t0)
    for cr_scale in (0.0, 0.1):
        y = step(MODEL_EPHEMERIS, params, cr_scale, x0_lu, 0.0, dt_tu, 100)
        h = 1e-4
        numeric = (step(MODEL_EPHEMERIS, params, cr_scale + h, x0_lu, 0.0, dt_tu, 100)[:6]
                   - step(MODEL_EPHEMERIS, params, cr_scale - h, x0_lu, 0.0, dt_tu, 100)[:6]) / (2 * h)
        gamma = y[42:48]
        assert np.linalg.norm(gamma[:3]) * LU_KM > 1e-3  # SRP moves it by metres per unit C_R over a day
        # Measured 7.3e-7 relative: the quotient's rounding floor (1e-16 LU of a state of ~1 LU over h = 1e-4).
        # A column without the gravity-gradient term, or off by the 1 + cr_scale factor, is off by > 1e-3.
        assert np.max(np.abs(numeric - gamma)) < 2e-6 * np.max(np.abs(gamma))
        scaled = pack_params(window, THIRD_BODIES, gms, GM_KM3_S2[399], 0.015 * (1 + cr_scale), t0)
        end_lu, phi = plain(MODEL_EPHEMERIS, scaled, x0_lu, 0.0, dt_tu, 100)
        assert np.array_equal(y[:6], end_lu)
        assert np.array_equal(y[6:42].reshape(6, 6), phi)


def _state_stm_step():
    """dynamics.model.propagate_state_stm_into behind a compiled caller (the model code read at run time, as the
    estimators read it): (state (6,), Phi (6, 6))."""
    import numba

    from liaison_cli.dynamics.model import STM_SIZE, propagate_state_stm_into

    @numba.njit
    def step(model, params, state, t_tu, dt_tu, n):
        y = np.empty(STM_SIZE)
        propagate_state_stm_into(model, params, state, t_tu, dt_tu, n, y, np.empty((5, STM_SIZE)))
        return y[0:6].copy(), y[6:].copy().reshape(6, 6)

    return step


def test_a_tabulated_truth_force_is_the_constant_force_when_constant(msl_window):
    """The per-run random force (model_error.truth_acceleration_sigma_m_s2) reaches the dated truth as a table
    at the epochs, linear between them: a constant table flies the constant force's path (to the
    integrator's tolerance), and a table that changes sign halfway does not."""
    t0, window, x0 = msl_window
    gms = np.array([GM_KM3_S2[int(b)] for b in THIRD_BODIES])
    times = t0 + np.arange(0.0, 2 * 86400.0 + 1.0, 1000.0)
    push = np.array([1e-11, -2e-11, 5e-12])  # km/s^2
    args = (x0, t0, times, window, THIRD_BODIES, gms, GM_KM3_S2[399], 0.0)
    constant = dop853_ephemeris_states(*args, acceleration_km_s2=push)
    table = dop853_ephemeris_states(*args, acceleration_table_km_s2=np.tile(push, (len(times), 1)))
    free = dop853_ephemeris_states(*args)
    assert np.linalg.norm(constant[-1, :3] - free[-1, :3]) > 0.1  # km: the push moves it (measured 0.37 km)
    assert np.max(np.linalg.norm(table[:, :3] - constant[:, :3], axis=1)) < 1e-6  # km: 1 mm (measured: 0)
    flipped = np.where((times < times[len(times) // 2])[:, None], push, -push)
    assert np.linalg.norm(dop853_ephemeris_states(*args, acceleration_table_km_s2=flipped)[-1, :3]
                          - constant[-1, :3]) > 0.05  # measured 0.18 km


def test_a_dated_runs_timeseries_carries_its_tdb_epochs(tmp_path, sky):
    """Issue 47: dated results carried only t_s. timeseries.parquet's epoch_tdb is each epoch on the TDB scale:
    its first value is ephemeris.epoch_utc on TDB by skyfield (to 10 us), and each later one t_s after it."""
    import pandas as pd

    from liaison_cli.scenario.loading import load_scenario
    from tests.conftest import SCENARIOS, run_cli_in_process

    out = tmp_path / "run"
    proc = run_cli_in_process("run", SCENARIOS / "eph_eml1_eml2_dsn.yaml", "--runs", "1", "--jobs", "1", "--quiet",
                              "--output", out)
    assert proc.returncode == 0, proc.stderr
    series = pd.read_parquet(out / "timeseries.parquet", columns=["t_s", "epoch_tdb"])
    ts, _ = sky
    start = load_scenario(SCENARIOS / "eph_eml1_eml2_dsn.yaml")[0].ephemeris.epoch()
    t = ts.utc(start.year, start.month, start.day, start.hour, start.minute,
               start.second + start.microsecond * 1e-6)
    expected = pd.Timestamp(t.tdb_strftime("%Y-%m-%dT%H:%M:%S.%f"))
    first = series.epoch_tdb.iloc[0]
    assert abs((first - expected).total_seconds()) < 1e-5
    elapsed = (series.epoch_tdb - first).dt.total_seconds().to_numpy()
    np.testing.assert_allclose(elapsed, series.t_s.to_numpy() - series.t_s.iloc[0], atol=1e-6)
