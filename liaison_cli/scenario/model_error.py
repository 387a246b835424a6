"""The `model_error` section: the filter's dynamics made to differ from the truth's on purpose, so that a study
can ask what a realistic mismodelling costs and whether the filter's sigma still tells the truth.

Each error is a fraction of the truth's value, either fixed (`*_bias`: the same in every run, so the error
budget's deterministic dynamics part carries it) or drawn per run (`*_sigma`: the filter's value is the
truth's times 1 + N(0, sigma), seeded from the scenario seed and the run index; sigma at most 0.2, so that a
drawn factor stays positive):
- C_R (dated dynamics): the solar-radiation-pressure coefficient; `ephemeris.cr_error_sigma` is the older
  spelling of `cr_sigma` (one of the two);
- the Moon's GM, for every dynamics model: in the CRTBP the mass ratio mu = GM_moon / (GM_earth + GM_moon)
  becomes mu (1 + f) / (1 + mu f); in the dated model the lunar point mass of the filter's model scales.
- an unmodelled constant acceleration in the truth (`truth_acceleration_m_s2`, the same in every run: the truth
  is propagated once per scenario), felt by every spacecraft on the dynamics model's axes;
- an unmodelled random acceleration in the truth (`truth_acceleration_sigma_m_s2` with
  `truth_acceleration_time_constant_s`): a first-order Gauss-Markov process per estimated spacecraft and axis,
  stationary from t0, sampled exactly at the measurement epochs and linear between them, drawn per run from
  its own stream of the run's seed (no other draw moves). Each run then flies and measures its own truth
  (campaign.engine.worker); the filter's empirical acceleration (filter.empirical_acceleration) with the
  same sigma and time constant is the matched model of it.
A clock-drift model error is the truth's deterministic drift the filter does not model: a clock's `mu1` (s/s)
and `mu2_per_s`. C_R can also be estimated (filter.estimated_parameters).
"""

from pydantic import Field, field_validator

from liaison_cli.scenario.spec_base import StrictModel


class ModelErrorSpec(StrictModel):
    """Fractions of the truth's values by which the filter's model is off (module docstring)."""

    cr_bias: float = Field(0.0, gt=-1, lt=1, description="dynamics: ephemeris: the filter's C_R is the truth's times "
                           "(1 + cr_bias) in every run (dimensionless)")
    cr_sigma: float = Field(0.0, ge=0, le=0.2, description="dynamics: ephemeris: the filter's C_R is also off by a "
                            "factor 1 + N(0, cr_sigma) drawn per run (the same as ephemeris.cr_error_sigma; give "
                            "one of the two) (dimensionless)")
    moon_gm_bias: float = Field(0.0, gt=-0.5, lt=0.5, description="the filter's lunar GM is the truth's times "
                                "(1 + moon_gm_bias) in every run (CRTBP: its mass ratio mu accordingly) "
                                "(dimensionless)")
    moon_gm_sigma: float = Field(0.0, ge=0, le=0.2, description="the filter's lunar GM is also off by a factor "
                                 "1 + N(0, moon_gm_sigma) drawn per run (dimensionless)")
    truth_acceleration_m_s2: tuple[float, float, float] = Field(
        (0.0, 0.0, 0.0), description="a constant acceleration every spacecraft's truth feels and the filter does "
        "not model, on the dynamics model's axes (crtbp: the rotating frame, x from the Earth to the Moon, z along "
        "the orbit normal; ephemeris: ICRF); each component at most 1e-5 (m/s^2)")

    truth_acceleration_sigma_m_s2: float = Field(
        0.0, ge=0, le=1e-5, description="a random acceleration each estimated spacecraft's truth feels and the "
        "filter does not model: first-order Gauss-Markov per axis of the dynamics model, this stationary 1-sigma, "
        "drawn per run (each run flies its own truth); 0: none (m/s^2)")
    truth_acceleration_time_constant_s: float | None = Field(
        None, gt=0, description="the random acceleration's correlation time tau (exp(-dt / tau) from one epoch to "
        "the next); needed with truth_acceleration_sigma_m_s2, at least measurement.interval_s (s)")

    @field_validator("truth_acceleration_m_s2")
    @classmethod
    def _bounded(cls, value):
        if any(not abs(a) <= 1e-5 for a in value):
            raise ValueError(f"{list(value)}: each component at most 1e-5 m/s^2 in size (SRP on a 0.01 m^2/kg "
                             "cannonball is ~7e-8)")
        return value
