"""The `moon_gravity` section: the Moon's gravity field beyond its point mass (GRAIL's GRGM1200A,
dynamics.lunar_gravity), for the truth and for the filter separately. The difference is model error the filter
lives with; the default process noise counts it (scenario.default_noise: the truth's field minus the filter's
along each orbit).

    moon_gravity: {degree: 50, filter_degree: 20}

degree: the truth's (2..EVALUATOR_MAX_DEGREE); filter_degree: the filter's (0 = a point-mass Moon; default: the
truth's, a filter whose field is the truth's); or filter_field: j2, the filter carrying the Moon's J2 alone in
closed form, as many flight filters do. Both dynamics models take it: the CRTBP with the Moon's principal axes on
the rotating frame (dynamics.crtbp_field), the dated model with the Moon turned by the IAU model
(dynamics.lunar_orientation, ephemeris_dynamics.add_moon_field).
"""

from typing import Literal

from pydantic import Field, model_validator

from liaison_cli.dynamics.lunar_gravity import EVALUATOR_MAX_DEGREE, FIELD_NAME
from liaison_cli.scenario.spec_base import StrictModel


class MoonGravitySpec(StrictModel):
    """The lunar field's degree and order in the truth and in the filter (module docstring)."""

    degree: int = Field(ge=2, le=EVALUATOR_MAX_DEGREE, description=f"the truth's {FIELD_NAME} degree and order "
                        f"(2..{EVALUATOR_MAX_DEGREE}; a 100 km orbit needs tens: docs/model.md)")
    filter_degree: int | None = Field(None, ge=0, le=EVALUATOR_MAX_DEGREE, description="the filter's degree and "
                                      "order, at most degree (0: a point-mass Moon; absent: the truth's)")
    filter_field: Literal["harmonics", "j2"] = Field("harmonics", description="the filter's field: harmonics, "
                                                     f"{FIELD_NAME} to filter_degree; j2: the Moon's J2 alone, in "
                                                     "closed form (no filter_degree then)")

    @model_validator(mode="after")
    def _filter_not_above_truth(self):
        if self.filter_field == "j2" and self.filter_degree is not None:
            raise ValueError(f"moon_gravity.filter_degree = {self.filter_degree} with filter_field: j2; allowed: one "
                             "of the two (j2 is the filter's whole field)")
        if self.filter_degree is not None and self.filter_degree > self.degree:
            raise ValueError(f"moon_gravity.filter_degree = {self.filter_degree}: at most moon_gravity.degree "
                             f"({self.degree}); a filter cannot model more of the field than the truth holds")
        return self

    @property
    def filter_degree_or_truth(self) -> int:
        return self.degree if self.filter_degree is None else self.filter_degree

    @property
    def filter_field_label(self) -> str:
        """The filter's field in words: 'J2' or 'degree N'."""
        return "J2" if self.filter_field == "j2" else f"degree {self.filter_degree_or_truth}"
