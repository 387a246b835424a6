"""Process noise with its position terms (issue 26, item 6): the continuous white-acceleration discretisation
of estimation.process_noise, against the continuous-time integral it discretises."""

import numpy as np
import pytest

from liaison_cli.estimation.process_noise import spacecraft_process_noise

SIGMA_A, DT = 1e-6, 187.5  # m/s^2, s (the lunar orbiter of eml2_lunar)


def _continuous(q, t):
    """The covariance a white acceleration of spectral density q builds in a double integrator over t."""
    return np.block([[np.eye(3) * q * t**3 / 3, np.eye(3) * q * t**2 / 2], [np.eye(3) * q * t**2 / 2, np.eye(3) * q * t]])


def test_k_steps_of_the_discrete_q_equal_the_continuous_integral_over_k_dt():
    """For a given spectral density q, Phi P Phi' + Q over k steps of a double integrator equals q's integral
    over k dt (q itself is sigma_a^2 dt: see estimation.process_noise)."""
    Q = spacecraft_process_noise(SIGMA_A, DT, "continuous_white_acceleration", 1.0, 1.0)
    phi = np.block([[np.eye(3), DT * np.eye(3)], [np.zeros((3, 3)), np.eye(3)]])
    P = np.zeros((6, 6))
    for _ in range(40):
        P = phi @ P @ phi.T + Q
    np.testing.assert_allclose(P, _continuous(SIGMA_A**2 * DT, 40 * DT), rtol=1e-12, atol=0)


def test_both_models_add_the_same_velocity_variance_and_only_one_has_position_terms():
    full = spacecraft_process_noise(SIGMA_A, DT, "continuous_white_acceleration", 1.0, 1.0)
    velocity_only = spacecraft_process_noise(SIGMA_A, DT, "velocity_only", 1.0, 1.0)
    np.testing.assert_allclose(np.diag(full)[3:], (SIGMA_A * DT) ** 2, rtol=1e-15)
    np.testing.assert_array_equal(np.diag(velocity_only)[3:], np.diag(full)[3:])
    assert not velocity_only[:3].any() and not velocity_only[:, :3].any()
    assert full[0, 0] == pytest.approx((SIGMA_A * DT) ** 2 * DT**2 / 3) and full[0, 3] == pytest.approx(
        (SIGMA_A * DT) ** 2 * DT / 2)
    assert np.all(np.linalg.eigvalsh(full) >= -1e-30)  # a covariance


def test_scaled_units_are_lu_and_vu():
    from liaison_cli.dynamics.constants import M_PER_LU, M_S_PER_VU

    si = spacecraft_process_noise(SIGMA_A, DT, "continuous_white_acceleration", 1.0, 1.0)
    scaled = spacecraft_process_noise(SIGMA_A, DT, "continuous_white_acceleration", M_PER_LU, M_S_PER_VU)
    scale = np.array([M_PER_LU] * 3 + [M_S_PER_VU] * 3)
    np.testing.assert_allclose(scaled * np.outer(scale, scale), si, rtol=1e-12)
