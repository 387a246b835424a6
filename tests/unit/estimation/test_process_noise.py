"""Process noise with its position terms (issue 26, item 6): the continuous white-acceleration discretisation
of estimation.process_noise, against the continuous-time integral it discretises."""

import numpy as np
import pytest

from liaison_cli.estimation.process_noise import psd_process_noise, spacecraft_process_noise

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


# --- the PSD convention (issue 34 item 4) -------------------------------------------------------------------

PSD = 3e-12  # m^2/s^3
DAY_S = 86400.0
INTERVALS_S = (60.0, 300.0, 600.0, 1800.0, 3600.0)  # each divides a day


def _phi(dt):
    return np.block([[np.eye(3), dt * np.eye(3)], [np.zeros((3, 3)), np.eye(3)]])


def _after(Q, dt, total_s):
    """Phi P Phi' + Q from P = 0 over total_s in steps of dt: the variance the process noise alone builds."""
    P = np.zeros((6, 6))
    for _ in range(round(total_s / dt)):
        P = _phi(dt) @ P @ _phi(dt).T + Q
    return P


def test_k_steps_of_a_psd_compose_to_the_q_of_k_dt():
    """For a fixed PSD, k steps of dt through the double integrator's transition equal one step of k dt."""
    for dt, k in ((187.5, 40), (60.0, 7), (1000.0, 3)):
        np.testing.assert_allclose(_after(psd_process_noise(PSD, dt, 1.0, 1.0), dt, k * dt),
                                   psd_process_noise(PSD, k * dt, 1.0, 1.0), rtol=1e-12, atol=0)
    np.testing.assert_allclose(psd_process_noise(PSD, DT, 1.0, 1.0), _continuous(PSD, DT), rtol=1e-15, atol=0)


def test_the_variance_per_day_of_a_psd_does_not_depend_on_the_interval_but_sigma_a_s_does():
    """A day of process noise under a fixed PSD: the same position and velocity variance at every interval.
    Under the per-step sigma_a convention (q = sigma_a^2 dt) it grows in proportion to the interval."""
    psd_day = [_after(psd_process_noise(PSD, dt, 1.0, 1.0), dt, DAY_S) for dt in INTERVALS_S]
    for P in psd_day[1:]:
        np.testing.assert_allclose(P, psd_day[0], rtol=1e-11, atol=0)
    np.testing.assert_allclose(psd_day[0][3, 3], PSD * DAY_S, rtol=1e-12)  # velocity: q T
    np.testing.assert_allclose(psd_day[0][0, 0], PSD * DAY_S**3 / 3, rtol=1e-12)  # position: q T^3 / 3
    sigma_a_day = [_after(spacecraft_process_noise(SIGMA_A, dt, "continuous_white_acceleration", 1.0, 1.0), dt, DAY_S)
                   for dt in INTERVALS_S]
    for dt, P in zip(INTERVALS_S, sigma_a_day):
        np.testing.assert_allclose(np.diag(P), np.diag(sigma_a_day[0]) * dt / INTERVALS_S[0], rtol=1e-11)
    assert sigma_a_day[-1][3, 3] / sigma_a_day[0][3, 3] == pytest.approx(INTERVALS_S[-1] / INTERVALS_S[0])


def test_the_continuous_sigma_a_form_is_the_psd_of_sigma_a_squared_dt():
    np.testing.assert_allclose(spacecraft_process_noise(SIGMA_A, DT, "continuous_white_acceleration", 1.0, 1.0),
                               psd_process_noise(SIGMA_A**2 * DT, DT, 1.0, 1.0), rtol=1e-14, atol=0)
