"""CRTBP physics: Jacobi constant, Jacobian and STM against finite differences, Table 1 periodicity."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from liaison_cli.dynamics.constants import MU, TU_S

MU_PARAMS = np.array([MU])  # the point-mass CRTBP's parameter vector (dynamics.crtbp_field)
from liaison_cli.dynamics.crtbp import derivative, jacobi_constant, jacobian
from liaison_cli.dynamics.integrators.dop853 import dop853_states
from liaison_cli.dynamics.integrators.rk4 import rk4_state_stm
from liaison_cli.orbits.catalog import CATALOG
from tests.conftest import LUNAR

STATES = {"eml2_halo": CATALOG["eml2_halo"].state(), "eml1_halo": CATALOG["eml1_halo"].state(), "lunar": LUNAR}
TEN_DAYS_TU = 10 * 86400.0 / TU_S
DT_TU = 187.5 / TU_S


def test_constants_give_the_papers_time_unit():
    assert 0.01215 < MU < 0.012151
    assert TU_S / 86400.0 == pytest.approx(4.3425, abs=1e-3)


@pytest.mark.parametrize("name", STATES)
def test_jacobi_constant_conserved_over_ten_days_by_truth_propagator(name):
    states = dop853_states(STATES[name], np.linspace(0.0, TEN_DAYS_TU, 50), MU)
    c = np.array([jacobi_constant(s, MU) for s in states])
    assert np.max(np.abs(c - c[0])) < 1e-10


@pytest.mark.parametrize("name", STATES)
def test_filter_rk4_conserves_jacobi_and_tracks_truth_over_ten_days(name):
    n_steps = int(round(TEN_DAYS_TU / DT_TU))
    x = STATES[name].copy()
    c0 = jacobi_constant(x, MU)
    for _ in range(n_steps):
        x = rk4_state_stm(x, DT_TU, 4, MU_PARAMS)[0]  # the default filter.rk4_substeps
    truth = dop853_states(STATES[name], np.array([0.0, n_steps * DT_TU]), MU)[-1]
    assert abs(jacobi_constant(x, MU) - c0) < 1e-10
    assert np.linalg.norm(x[:3] - truth[:3]) * 384400e3 < 1.0  # metres


@pytest.mark.parametrize("name", STATES)
def test_compiled_truth_matches_a_tight_dop853_over_ten_days(name):
    """The truth propagator (compiled RK4, steps of at most 10 s) against scipy DOP853 at rtol 1e-13: within
    5 mm over 10 days, sampled every 187.5 s (measured: 0.19 / 0.15 / 2.0 mm for EML2, EML1 and the lunar
    orbiter, where DOP853 at the former rtol 1e-12 is 1.5 / 0.6 / 19.9 mm off), and it conserves the Jacobi
    constant."""
    from liaison_cli.dynamics.model import crtbp_model

    times = np.arange(0.0, TEN_DAYS_TU, DT_TU)
    compiled = crtbp_model(MU).truth_states(STATES[name], times)
    tight = dop853_states(STATES[name], times, MU, rtol=1e-13, atol=1e-15)
    assert np.max(np.linalg.norm(compiled[:, :3] - tight[:, :3], axis=1)) * 384400e3 < 5e-3  # metres
    c = np.array([jacobi_constant(s, MU) for s in compiled[::100]])
    assert np.max(np.abs(c - c[0])) < 1e-11


@pytest.mark.parametrize("name", STATES)
def test_jacobian_matches_central_differences(name):
    x = STATES[name]
    analytic = jacobian(x, MU)
    numeric = np.empty((6, 6))
    for j in range(6):
        h = 1e-7 * max(1.0, abs(x[j]))
        e = np.zeros(6)
        e[j] = h
        numeric[:, j] = (derivative(x + e, MU) - derivative(x - e, MU)) / (2 * h)
    assert np.allclose(analytic, numeric, rtol=1e-6, atol=1e-7 * np.abs(analytic).max())


@pytest.mark.parametrize("name", STATES)
@pytest.mark.parametrize("span_steps", [1, 96])  # one measurement interval; ~5 hours chained
def test_stm_matches_central_differences(name, span_steps):
    x0 = STATES[name]
    phi = np.eye(6)
    x = x0.copy()
    for _ in range(span_steps):
        x, step_phi = rk4_state_stm(x, DT_TU, 8, MU_PARAMS)
        phi = step_phi @ phi

    def flow(state):
        for _ in range(span_steps):
            state = rk4_state_stm(state, DT_TU, 8, MU_PARAMS)[0]
        return state

    numeric = np.empty((6, 6))
    for j in range(6):
        h = 1e-6 if j < 3 else 1e-6 * 0.2
        e = np.zeros(6)
        e[j] = h
        numeric[:, j] = (flow(x0 + e) - flow(x0 - e)) / (2 * h)
    scale = np.abs(phi).max()
    assert np.max(np.abs(phi - numeric)) < 1e-6 * scale


@pytest.mark.parametrize("name", STATES)
@pytest.mark.parametrize("interval_s", [187.5, 600.0])
def test_the_stm_on_a_coarser_grid_keeps_the_state_and_stays_near_dop853(name, interval_s):
    """rk4_state_stm_into takes the state by its substeps and Phi by a quarter of them in steps of at most
    200 s: the state is bit for bit that of every substep on the 42 equations (rk4_variational), and Phi over
    one interval is within 1e-7 of DOP853 at rtol 1e-13 (relative to its largest entry; the lunar orbiter:
    5.2e-8 at 187.5 s; at 600 s 5.4e-6 before the 200 s bound), at 48 points along each orbit."""
    from liaison_cli.dynamics.crtbp import state_stm_derivative
    from liaison_cli.dynamics.integrators.rk4 import rk4_variational, stm_steps

    dt = interval_s / TU_S
    assert stm_steps(dt, 4) == (1 if interval_s < 200 else 3) and stm_steps(dt, 2) == (1 if interval_s < 200 else 2)
    x = STATES[name].copy()
    worst = 0.0
    for _ in range(48):
        state, phi = rk4_state_stm(x, dt, 4, MU_PARAMS)
        assert np.array_equal(state, rk4_variational(x, dt, 4, MU_PARAMS)[0])
        y0 = np.concatenate([x, np.eye(6).ravel()])
        ref = solve_ivp(lambda t, v: state_stm_derivative(v, MU), (0.0, dt), y0, method="DOP853", rtol=1e-13,
                        atol=1e-16).y[6:, -1].reshape(6, 6)
        worst = max(worst, np.abs(phi - ref).max() / np.abs(ref).max())
        x = state
    assert worst < 1e-7  # the halos: at rounding; the lunar orbiter: coarser than every substep (2e-10)


@pytest.mark.parametrize("interval_s", [187.5, 600.0])
def test_the_coarser_stm_through_the_nrho_perilune(interval_s):
    """The catalogue's Gateway NRHO through its 3,250 km perilune, the fastest dynamics a shipped CRTBP
    scenario flies: over the 16 intervals around it, Phi within 5e-6 of DOP853 at rtol 1e-13 (measured 2.7e-6
    at 187.5 s and 3.3e-6 at 600 s, in 200 s steps; benchmarks/bare_loop.py --accuracy weighs it against a
    settled 1-sigma move of the state)."""
    from liaison_cli.dynamics.crtbp import state_stm_derivative

    x0 = CATALOG["nrho_gateway"].state()
    span = 7 * 86400.0 / TU_S
    orbit = solve_ivp(lambda t, s: derivative(s, MU), (0.0, span), x0, method="DOP853", rtol=1e-12, atol=1e-13,
                      dense_output=True)
    times = np.linspace(0.0, span, 20000)
    perilune = times[np.argmin(np.linalg.norm(orbit.sol(times).T[:, :3] - [1.0 - MU, 0.0, 0.0], axis=1))]
    dt = interval_s / TU_S
    worst = 0.0
    for j in range(-8, 8):
        x = orbit.sol(perilune + j * dt)
        phi = rk4_state_stm(x, dt, 4, MU_PARAMS)[1]
        ref = solve_ivp(lambda t, v: state_stm_derivative(v, MU), (0.0, dt), np.concatenate([x, np.eye(6).ravel()]),
                        method="DOP853", rtol=1e-13, atol=1e-16).y[6:, -1].reshape(6, 6)
        worst = max(worst, np.abs(phi - ref).max() / np.abs(ref).max())
    assert 1e-7 < worst < 5e-6  # coarser than every substep here, and bounded


def _y_crossings(state, t_max):
    event = lambda t, s: s[1]  # noqa: E731
    sol = solve_ivp(lambda t, s: derivative(s, MU), (0, t_max), state, method="DOP853",
                    rtol=1e-12, atol=1e-13, events=event)
    return sol.t_events[0][1:], sol.y_events[0][1:]


@pytest.mark.parametrize(
    "name, period_tu, closure_lu",
    [("eml2_halo", 3.3974, 1e-5), ("eml1_halo", 2.752, 3e-4)],
)
def test_table1_halo_states_are_periodic(name, period_tu, closure_lu):
    x0 = CATALOG[name].state()
    times, states = _y_crossings(x0, 1.1 * period_tu)
    assert len(times) == 2  # half period (far side) and the full period
    assert times[-1] == pytest.approx(period_tu, abs=2e-3)
    assert times[0] == pytest.approx(period_tu / 2, abs=2e-3)
    assert np.max(np.abs(states[-1] - x0)) < closure_lu
    # A symmetric periodic orbit crosses y = 0 perpendicularly at the half period.
    assert abs(states[0][3]) < 1e-4 and abs(states[0][5]) < 1e-4


@pytest.mark.parametrize("name", STATES)
def test_hot_loop_rhs_equals_an_independent_rhs(name):
    # state_stm_rhs (every integrator's Eq. 6-8 and Eq. 11, scalar code) against benchmarks/reference.py's
    # own right-hand side, written with numpy from the equations and sharing nothing with the package.
    from benchmarks.reference import _rhs_plain
    from liaison_cli.dynamics.crtbp import state_stm_rhs

    rng = np.random.default_rng(4)
    phi = rng.standard_normal((6, 6))
    y = np.concatenate([STATES[name], phi.ravel()])
    out = np.empty(42)
    state_stm_rhs(y, MU, out)
    plain = _rhs_plain(0.0, y, MU)
    assert np.allclose(out[:6], plain[:6], rtol=1e-13, atol=1e-15)
    assert np.allclose(out[6:], plain[6:], rtol=1e-12, atol=1e-12)
    assert np.allclose(out[:6], derivative(STATES[name], MU), rtol=1e-14, atol=1e-16)
    assert np.allclose(out[6:].reshape(6, 6), jacobian(STATES[name], MU) @ phi, rtol=1e-12, atol=1e-12)


def test_the_truths_unmodelled_acceleration_moves_it_by_half_a_t_squared():
    """model_error.truth_acceleration_m_s2 in the CRTBP truth: over t = 1,000 s a push a = 1e-6 m/s^2 along a
    rotating axis moves the EML2 halo by a t^2 / 2 = 0.5 m along it, and the Coriolis term -2 w x v turns it by
    w a t^3 / 3 = 0.89 mm (w = 1 rad/TU) toward -y for a push along x, +x for one along y; the gravity
    gradient's part is below 1e-5 m here (measured 3e-6). Zero leaves the truth unchanged to the bit."""
    from liaison_cli.dynamics.constants import M_PER_LU, TU_S
    from liaison_cli.dynamics.model import crtbp_model

    times_tu = np.array([0.0, 500.0, 1000.0]) / TU_S
    plain = crtbp_model(MU).truth_states(STATES["eml2_halo"], times_tu)
    assert np.array_equal(crtbp_model(MU, (0.0, 0.0, 0.0)).truth_states(STATES["eml2_halo"], times_tu), plain)
    for axis in range(3):
        push = np.zeros(3)
        push[axis] = 1e-6
        moved = (crtbp_model(MU, push).truth_states(STATES["eml2_halo"], times_tu)[-1, :3] - plain[-1, :3]) * M_PER_LU
        coriolis = 1.0 / TU_S * 1e-6 * 1000.0**3 / 3.0
        expected = 0.5 * push / 1e-6 + coriolis * np.array([push[1], -push[0], 0.0]) / 1e-6
        assert np.max(np.abs(moved - expected)) < 1e-5
