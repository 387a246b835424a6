"""Empirical (first-order Gauss-Markov) accelerations, filter.empirical_acceleration: the noise model against
a simulated loop and against its own semigroup, the kinematic gains against the matrix exponential, the
coupled covariance step against the dense product, the scenario rules, and a run whose truth feels an
acceleration the filter's dynamics lack."""

import numpy as np
import pytest
from scipy.linalg import expm

from liaison_cli.estimation.blocks import BLOCK_EMPIRICAL, BLOCK_SPACECRAFT, ROLE_EMPIRICAL, StateBlock, StateLayout, owner_name
from liaison_cli.estimation.ekf import predict_covariance_blocks
from liaison_cli.estimation.process_noise import (coupled_process_noise, gauss_markov_gains,
                                                  gauss_markov_process_noise)

SIGMA, TAU, DT = 2e-8, 3600.0, 600.0


def _per_axis(Q9):
    return Q9[::3, ::3]  # the x axis' [r, v, w] (kron(per_axis, I3))


def _F(tau):
    return np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0 / tau]])


@pytest.mark.parametrize("tau", [200.0, TAU, 1e6, 1e9, 1e12, 1e300])
def test_gains_are_the_kinematic_transition(tau):
    """m, and the position and velocity gains, are the third column of exp(F dt), for a memory from about one
    step to 'constant': the closed form tau dt - tau^2 (1 - m) had lost its sign by tau = 1e11 s (cancellation)
    and overflowed at 1e300."""
    decay, gain_r, gain_v = gauss_markov_gains(tau, DT)
    Phi = expm(_F(tau) * DT)
    assert np.allclose([gain_r, gain_v, decay], Phi[:, 2], rtol=1e-12, atol=0)


def test_noise_adds_up_over_steps_and_holds_the_steady_state():
    """Q(2 dt) = Phi(dt) Q(dt) Phi(dt)^T + Q(dt) (no dependence on how the interval is cut), and the
    acceleration's own variance is sigma^2 (1 - m^2): from a steady state sigma^2 it stays sigma^2."""
    one = _per_axis(gauss_markov_process_noise(SIGMA, TAU, DT, 1.0, 1.0))
    two = _per_axis(gauss_markov_process_noise(SIGMA, TAU, 2 * DT, 1.0, 1.0))
    Phi = expm(_F(TAU) * DT)
    assert np.allclose(Phi @ one @ Phi.T + one, two, rtol=1e-9, atol=0)
    decay = np.exp(-DT / TAU)
    assert one[2, 2] == pytest.approx(SIGMA**2 * (1 - decay**2), rel=1e-10)
    assert decay**2 * SIGMA**2 + one[2, 2] == pytest.approx(SIGMA**2, rel=1e-10)


def test_noise_matches_a_simulated_loop():
    """20,000 paths of w' = -w / tau + u (u white, PSD 2 sigma^2 / tau) integrated in 600 exact sub-steps for
    w and the kinematics: their sample covariance of [r, v, w] after dt, from zero, is Q within 4 standard
    errors of each entry."""
    rng = np.random.default_rng(11)
    paths, steps = 20_000, 600
    h = DT / steps
    decay = np.exp(-h / TAU)
    r, v, w = np.zeros(paths), np.zeros(paths), np.zeros(paths)
    for _ in range(steps):
        w_next = decay * w + SIGMA * np.sqrt(1 - decay**2) * rng.standard_normal(paths)
        mean_w = 0.5 * (w + w_next)  # trapezoid over the sub-step
        r += v * h + 0.5 * mean_w * h**2
        v += mean_w * h
        w = w_next
    sample = np.cov(np.vstack([r, v, w]))
    Q = _per_axis(gauss_markov_process_noise(SIGMA, TAU, DT, 1.0, 1.0))
    scale = np.sqrt(np.outer(np.diag(Q), np.diag(Q)))
    standard_error = scale * np.sqrt(2.0 / paths)
    assert np.all(np.abs(sample - Q) < 4 * standard_error + 1e-3 * scale)


def test_coupled_prediction_is_the_dense_product():
    """Two spacecraft with an acceleration block each: the block products on Q~ then the couplings equal
    Phi P Phi^T + Q with the full coupled Q, to 1e-13 relative."""
    rng = np.random.default_rng(3)
    layout = StateLayout((StateBlock(BLOCK_SPACECRAFT, 6, "A"), StateBlock(BLOCK_SPACECRAFT, 6, "B"),
                          StateBlock(BLOCK_EMPIRICAL, 3, owner_name(ROLE_EMPIRICAL, "A")),
                          StateBlock(BLOCK_EMPIRICAL, 3, owner_name(ROLE_EMPIRICAL, "B"))))
    kind, start, size, partner = layout.arrays()
    assert list(partner) == [-1, -1, 0, 6]
    n, tau, dt = layout.n, 0.3, 0.002
    decay, gain_r, gain_v = gauss_markov_gains(tau, dt)
    Phi = np.zeros((n, n))
    for s, a in ((0, 12), (6, 15)):
        Phi[s : s + 6, s : s + 6] = np.eye(6) + 0.01 * rng.standard_normal((6, 6))
        Phi[a : a + 3, a : a + 3] = decay * np.eye(3)
        Phi[s : s + 3, a : a + 3] = gain_r * np.eye(3)
        Phi[s + 3 : s + 6, a : a + 3] = gain_v * np.eye(3)
    A = rng.standard_normal((n, n))
    P = A @ A.T + n * np.eye(n)
    Q = np.zeros((n, n))
    for s, a in ((0, 12), (6, 15)):
        rows = np.r_[s : s + 6, a : a + 3]
        Q[np.ix_(rows, rows)] += gauss_markov_process_noise(1.0, tau, dt, 1.0, 1.0)
    Q_reduced = coupled_process_noise(Q, [(0, 12), (6, 15)], tau, dt)
    out = predict_covariance_blocks(P, Phi, Q_reduced, np.empty((n, n)), kind, start, size)
    dense = Phi @ P @ Phi.T + Q
    assert np.max(np.abs(out - dense)) < 1e-13 * np.max(np.abs(dense))
    # The reduction is not a rounding matter: it moves the position noise by a factor of ~2.7 here.
    assert np.all(np.abs(np.diag(Q_reduced)[:3] / np.diag(Q)[:3] - 1) > 0.5)


def test_the_dense_process_noise_undoes_the_reduction():
    """The initial batch's dense step P <- Phi P Phi' + Q takes the physical Q back from the reduced form the
    EKF's coupled step takes: (I + G) (I - G) = I since G^2 = 0, so the round trip is exact to rounding."""
    from liaison_cli.dynamics.constants import TU_S
    from liaison_cli.estimation.process_noise import uncoupled_process_noise

    layout = StateLayout((StateBlock(BLOCK_SPACECRAFT, 6, "A"), StateBlock(BLOCK_SPACECRAFT, 6, "B"),
                          StateBlock(BLOCK_EMPIRICAL, 3, owner_name(ROLE_EMPIRICAL, "B"))))
    assert layout.empirical_couplings() == [(6, 12)]
    rng = np.random.default_rng(7)
    root = rng.normal(size=(15, 15))
    Q = root @ root.T
    tau, dt = TAU / TU_S, DT / TU_S  # the filter's time unit, as the EKF and the initial batch take them
    Q[:12, 12:] *= 1e-3  # accelerations (LU/TU^2) are small next to positions and velocities
    Q[12:, :12] *= 1e-3
    Q[12:, 12:] *= 1e-6
    reduced = coupled_process_noise(Q, layout.empirical_couplings(), tau, dt)
    assert np.max(np.abs(reduced - Q)) > 1e-6 * np.max(np.abs(Q))  # the reduction moves Q (here by 1.4e-6)
    back = uncoupled_process_noise(reduced, layout.empirical_couplings(), tau, dt)
    assert np.max(np.abs(back - Q)) < 1e-12 * np.max(np.abs(Q))


@pytest.mark.parametrize("edits, fragment", [
    ({"filter": {"empirical_acceleration": {"sigma_m_s2": 1e-8, "time_constant_s": 60}}},
     "time_constant_s = 60 is shorter than measurement.interval_s = 187.5"),
    ({"filter": {"empirical_acceleration": {"sigma_m_s2": 1e-8, "time_constant_s": 86400}},
      "estimator": "batch", "batch": {"span_days": 1.0}}, "estimator batch does not carry empirical accelerations"),
    ({"filter": {"empirical_acceleration": {"sigma_m_s2": 1e-3, "time_constant_s": 86400}}}, "sigma_m_s2"),
], ids=["tau-below-interval", "batch", "too-large"])
def test_rules_are_one_line(edits, fragment):
    from liaison_cli.errors import ScenarioError
    from liaison_cli.scenario.loading import read_scenario_text, validate_scenario
    from tests.conftest import SCENARIOS

    data = read_scenario_text(SCENARIOS / "smoke.yaml")[0]
    for key, value in edits.items():
        if isinstance(value, dict):
            data.setdefault(key, {}).update(value)
        else:
            data[key] = value
    with pytest.raises(ScenarioError) as refused:
        validate_scenario(data, "s.yaml")
    assert fragment in str(refused.value) and "\n" not in str(refused.value)
