"""State-noise compensation (SNC) for a spacecraft's 6-state block: the process noise Q of one step dt.

Two models, both driven by sigma_a (m/s^2, the scenario's `process_noise_accel_m_s2`):
- `continuous_white_acceleration` (default): an acceleration that is white noise in continuous time with
  spectral density q = sigma_a^2 dt, integrated exactly over the step (Bar-Shalom, Li & Kirubarajan,
  "Estimation with Applications to Tracking and Navigation", §6.2.2; Tapley, Schutz & Born §4.9):
      Q = q [[dt^3/3 I, dt^2/2 I], [dt^2/2 I, dt I]].
  q = sigma_a^2 dt keeps the velocity variance added per step at (sigma_a dt)^2, the value of the
  velocity-only form, so a scenario's tuning keeps its meaning; the position terms are what that velocity
  noise does to the position within the step. For a given q, k steps of a double integrator sum to the
  same matrix with dt -> k dt (tested). But q itself is sigma_a^2 dt, dt the measurement interval: as in
  the velocity-only form, the noise intensity grows with the interval, so a sweep over
  measurement.interval_s also changes the process noise (by the ratio of the intervals).
- `velocity_only`: (sigma_a dt)^2 on the velocity diagonal and nothing else (the form used before; named so
  a reproduction can ask for it).
Units: the block is returned in the estimators' scaled units (LU, LU/TU) given the scales.
"""

import numpy as np

PROCESS_NOISE_MODELS = ("continuous_white_acceleration", "velocity_only")


def spacecraft_process_noise(sigma_a_m_s2: float, dt_s: float, model: str, m_per_lu: float,
                             m_s_per_vu: float) -> np.ndarray:
    """Q (6, 6) of one step dt_s for a spacecraft block, in LU and LU/TU (module docstring)."""
    velocity_var = (sigma_a_m_s2 * dt_s) ** 2  # (m/s)^2 per step: both models
    Q = np.zeros((6, 6))
    Q[3:, 3:] = np.eye(3) * velocity_var / m_s_per_vu**2
    if model == "velocity_only":
        return Q
    if model != "continuous_white_acceleration":
        raise ValueError(f"process noise model {model!r}: allowed {', '.join(PROCESS_NOISE_MODELS)}")
    q = velocity_var / dt_s  # spectral density, m^2/s^3
    Q[:3, :3] = np.eye(3) * q * dt_s**3 / 3.0 / m_per_lu**2
    cross = np.eye(3) * q * dt_s**2 / 2.0 / (m_per_lu * m_s_per_vu)
    Q[:3, 3:] = cross
    Q[3:, :3] = cross
    return Q
