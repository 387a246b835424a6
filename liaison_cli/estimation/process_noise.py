"""State-noise compensation (SNC) for a spacecraft's 6-state block: the process noise Q of one step dt.

Two conventions, chosen per spacecraft by the scenario (FilterSpec.process_noise_of: a spacecraft's own key,
else the filter's, else a default PSD derived for the scenario: scenario.default_noise):
- A power spectral density q (m^2/s^3, `process_noise_psd_m2_s3`; the default's convention): an
  acceleration that is white noise in continuous time, isotropic (the same q on every axis, so the same
  matrix in the inertial frame and in any rotated one such as radial / in-track / cross-track; a density per
  RIC axis is estimation.ric_noise's, rebuilt at every step), integrated exactly over the step through the double integrator
  (Bar-Shalom, Li & Kirubarajan, "Estimation with Applications to Tracking and Navigation", §6.2.2; Tapley,
  Schutz & Born §4.9), `psd_process_noise`:
      Q(dt) = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]].
  q does not depend on the step: k steps of dt through the transition [[I, dt I], [0, I]] add up to Q(k dt)
  (tested), so the noise a day adds is the same at any measurement interval.
- The papers' per-step sigma_a (m/s^2, `process_noise_accel_m_s2`: the convention of 001/003/004's
  reproductions), `spacecraft_process_noise`, in the form filter.process_noise_model names:
  - `continuous_white_acceleration` (default): the PSD form above with q = sigma_a^2 dt, dt the measurement
    interval, so the velocity variance added per step is (sigma_a dt)^2. q grows with the interval: a sweep over
    measurement.interval_s under this convention also changes the noise per day, by the ratio of the intervals.
  - `velocity_only`: (sigma_a dt)^2 on the velocity diagonal and nothing else (the form before issue 26).
  A PSD always takes the continuous form; process_noise_model applies to sigma_a only.
Empirical accelerations (dynamic model compensation, DMC; `filter.empirical_acceleration`): a first-order
Gauss-Markov acceleration w per spacecraft, three states on the dynamics model's axes (Tapley, Schutz & Born
§4.9; Bar-Shalom et al. §8.2), w' = -w / tau + u with u white of PSD 2 sigma^2 / tau, so that w's steady-state
sigma is sigma whatever tau. Over a step dt its transition is m = exp(-dt / tau) on w, and it moves its
spacecraft through the kinematic gains position tau dt - tau^2 (1 - m) and velocity tau (1 - m) per unit of
w (`gauss_markov_gains`; the dynamics' share of that coupling over a step is left out: in the CRTBP's rotating
axes the Coriolis term, Omega dt ~ 5e-4 of it at 187.5 s, and the gravity gradient, (GM / r^3) dt^2 ~ 1e-3 for
the lunar orbiter at perilune and ~1e-7 at EML2). `gauss_markov_process_noise` is the exact Q of [r, v, w] over dt for that
linear model (Van Loan's matrix exponential, Van Loan 1978 "Computing integrals involving the matrix
exponential"), per axis, added to the spacecraft's own SNC.
Units: blocks are returned in the estimators' scaled units (LU, LU/TU) given the scales.
"""

import numpy as np
from numba import njit

PROCESS_NOISE_MODELS = ("continuous_white_acceleration", "velocity_only")



def psd_process_noise(q_m2_s3: float, dt_s: float, m_per_lu: float, m_s_per_vu: float) -> np.ndarray:
    """Q (6, 6) of one step dt_s of an isotropic continuous white acceleration of PSD q_m2_s3, in LU and LU/TU."""
    Q = np.zeros((6, 6))
    Q[:3, :3] = np.eye(3) * q_m2_s3 * dt_s**3 / 3.0 / m_per_lu**2
    cross = np.eye(3) * q_m2_s3 * dt_s**2 / 2.0 / (m_per_lu * m_s_per_vu)
    Q[:3, 3:] = cross
    Q[3:, :3] = cross
    Q[3:, 3:] = np.eye(3) * q_m2_s3 * dt_s / m_s_per_vu**2
    return Q


def spacecraft_process_noise(sigma_a_m_s2: float, dt_s: float, model: str, m_per_lu: float,
                             m_s_per_vu: float) -> np.ndarray:
    """Q (6, 6) of one step dt_s under the per-step sigma_a convention, in LU and LU/TU (module docstring)."""
    velocity_var = (sigma_a_m_s2 * dt_s) ** 2  # (m/s)^2 per step: both forms
    if model == "velocity_only":
        Q = np.zeros((6, 6))
    elif model == "continuous_white_acceleration":
        Q = psd_process_noise(velocity_var / dt_s, dt_s, m_per_lu, m_s_per_vu)  # q = sigma_a^2 dt
    else:
        raise ValueError(f"process noise model {model!r}: allowed {', '.join(PROCESS_NOISE_MODELS)}")
    Q[3:, 3:] = np.eye(3) * velocity_var / m_s_per_vu**2  # q dt to the last bit, as the reproductions recorded it
    return Q


@njit(cache=True)
def gauss_markov_gains(tau: float, dt: float):
    """(m, position gain, velocity gain) of a first-order Gauss-Markov acceleration over one step dt (module
    docstring): w(t + dt) = m w(t); it adds position gain * w to the position and velocity gain * w to the
    velocity. Any consistent time unit (tau and dt in the same one; the gains in it and its square).

    With x = dt / tau the gains are tau (1 - e^-x) = -dt expm1(-x) / x and tau^2 (x - 1 + e^-x) = dt^2 g(x),
    g(x) = (x + expm1(-x)) / x^2. For small x (a long memory, the usual way to ask for a near-constant force)
    the difference cancels, so g takes its series 1/2 - x/6 + x^2/24 - x^3/120 + x^4/720 below x = 1e-2
    (next term x^5/5040: 2e-14 of g there); no power of tau is formed, so any tau > 0 is finite."""
    x = dt / tau
    decay = np.exp(-x)
    velocity_gain = -dt * np.expm1(-x) / x if x > 0.0 else dt
    if x < 1e-2:
        position_factor = 0.5 - x / 6.0 + x * x / 24.0 - x**3 / 120.0 + x**4 / 720.0
    else:
        position_factor = (x + np.expm1(-x)) / (x * x)
    return decay, dt * dt * position_factor, velocity_gain


def gauss_markov_process_noise(sigma_m_s2: float, tau_s: float, dt_s: float, m_per_lu: float,
                               m_s_per_vu: float) -> np.ndarray:
    """Q (9, 9) over one step dt_s of [position (3), velocity (3), w (3)] driven by a Gauss-Markov acceleration
    of steady-state sigma sigma_m_s2 and time constant tau_s (module docstring), in LU, LU/TU and LU/TU^2.

    Per axis, F = [[0, 1, 0], [0, 0, 1], [0, 0, -1/tau]], G = [0, 0, 1]^T, PSD q = 2 sigma^2 / tau: Van Loan's
    exp([[-F, G q G^T], [0, F^T]] dt) = [[., Phi^-1 Q], [0, Phi^T]] gives Q = Phi (Phi^-1 Q)."""
    from scipy.linalg import expm  # here: scipy.linalg costs every command about 0.27 s to import

    F = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0 / tau_s]])
    noise = np.zeros((3, 3))
    noise[2, 2] = 2.0 * sigma_m_s2**2 / tau_s
    exponential = expm(np.block([[-F, noise], [np.zeros((3, 3)), F.T]]) * dt_s)
    per_axis = exponential[3:, 3:].T @ exponential[:3, 3:]
    per_axis = 0.5 * (per_axis + per_axis.T)
    m_s2_per_au = m_s_per_vu**2 / m_per_lu  # the acceleration unit LU/TU^2 in m/s^2
    scale = np.array([m_per_lu, m_s_per_vu, m_s2_per_au])
    per_axis = per_axis / np.outer(scale, scale)
    return np.kron(per_axis, np.eye(3))  # rows/columns ordered [r (3), v (3), w (3)]


def coupled_process_noise(Q: np.ndarray, couplings, tau: float, dt: float) -> np.ndarray:
    """Q~ = (I + G)^-1 Q (I + G)^-T = (I - G) Q (I - G)^T, the form of Q that ekf.predict_covariance_into takes
    when empirical-acceleration blocks are in the state: G holds, at (the spacecraft's position and velocity
    rows, the acceleration's columns), the kinematic gains over the decay m (gauss_markov_gains; G^2 = 0).
    couplings: (spacecraft block start, acceleration block start) pairs; tau, dt in the state's time unit
    (TU: the gains are in LU per LU/TU^2 and LU/TU per LU/TU^2)."""
    return _congruence(Q, -_coupling_matrix(Q.shape, couplings, tau, dt))


def uncoupled_process_noise(Q_reduced: np.ndarray, couplings, tau: float, dt: float) -> np.ndarray:
    """The inverse of coupled_process_noise: Q = (I + G) Q~ (I + G)^T, the process noise of a dense step
    P <- Phi P Phi' + Q (the initial batch's accumulation)."""
    return _congruence(Q_reduced, _coupling_matrix(Q_reduced.shape, couplings, tau, dt))


def _congruence(Q: np.ndarray, G: np.ndarray) -> np.ndarray:
    """(I + G) Q (I + G)^T, expanded and symmetrised."""
    out = Q + G @ Q + Q @ G.T + G @ Q @ G.T
    return 0.5 * (out + out.T)


def _coupling_matrix(shape, couplings, tau: float, dt: float) -> np.ndarray:
    """G of coupled_process_noise: the kinematic gains over the decay at (spacecraft rows, acceleration
    columns)."""
    decay, gain_r, gain_v = gauss_markov_gains(tau, dt)
    G = np.zeros(shape)
    for s, a in couplings:
        for i in range(3):
            G[s + i, a + i] = gain_r / decay
            G[s + 3 + i, a + i] = gain_v / decay
    return G
