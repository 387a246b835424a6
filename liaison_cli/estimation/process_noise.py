"""State-noise compensation (SNC) for a spacecraft's 6-state block: the process noise Q of one step dt.

Two conventions, chosen per spacecraft by the scenario (FilterSpec.process_noise_of: a spacecraft's own key,
else the filter's, else the default PSD):
- A power spectral density q (m^2/s^3, `process_noise_psd_m2_s3`; the default, DEFAULT_PSD_M2_S3): an
  acceleration that is white noise in continuous time, isotropic (the same q on every axis, so the same
  matrix in the inertial frame and in any rotated one such as radial / in-track / cross-track; a different
  density per RIC axis is not offered), integrated exactly over the step through the double integrator
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
Units: blocks are returned in the estimators' scaled units (LU, LU/TU) given the scales.
"""

import numpy as np

PROCESS_NOISE_MODELS = ("continuous_white_acceleration", "velocity_only")

# The PSD of a scenario that gives neither process-noise key (m^2/s^3). It adds sqrt(q * 86400 s) = 0.29 mm/s
# of velocity 1-sigma per day per axis (and sqrt(q T^3 / 3) = 15 m of position over T = 1 d on its own), the
# order of the velocity an unmodelled 1e-8 m/s^2 (a 10 % error of the SRP on a spacecraft of 0.02 m^2/kg,
# C_R 1.3) builds in a day, 0.86 mm/s. It is also the order of the former default, sigma_a = 1e-7 m/s^2 at
# 001's interval of 187.5 s: q = 1.9e-12, rounded down to its decade.
DEFAULT_PSD_M2_S3 = 1e-12


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
