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
Not offered yet: an unmodelled acceleration in the truth, a clock-drift model error, C_R as an estimated state.
"""

from pydantic import Field

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
