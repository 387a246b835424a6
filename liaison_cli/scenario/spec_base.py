"""What every scenario section shares: the strict base model (frozen, unknown keys refused with the allowed
ones named, numbers finite), the name pattern, and the JSON Schema words the sections use."""

import types
import typing
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

from liaison_cli.scenario.schema_rules import Rule, all_of, given, not_given, when


NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.\-]*$"
# A name becomes part of file names (results/<name>, an export's <scenario>-<participant> files): at most this
# long, far below a file system's 255 bytes (a 300-character name passed validation and failed after setup).
NAME_MAX_LENGTH = 64
UNIQUE = {"uniqueItems": True}  # the JSON Schema word for a list the loader refuses repeats in


def allowed_names(schema: dict, what: str) -> None:
    """The JSON Schema's `enum` of a name a validator checks, for editors to offer; imported when the schema is
    generated, as the validators import them when they check (a scenario without them need not)."""
    if what == "mission":
        from liaison_cli.orbits.departure_missions import departure_mission_names as names
    else:
        from liaison_cli.dynamics.dsn_sites import dsn_site_names as names
    schema["enum"] = [*names(), None]


# A section (the filter, or a spacecraft) gives its process noise in at most one convention
# (estimation.process_noise: a PSD, a PSD per radial / in-track / cross-track axis, or the papers'
# per-step sigma_a).
# A density per radial / in-track / cross-track axis, each >= 0 (m^2/s^3): the type carries the bound, so the
# JSON Schema and the loader say it from this one declaration.
RicDensities = tuple[Annotated[float, Field(ge=0)], Annotated[float, Field(ge=0)], Annotated[float, Field(ge=0)]]


PROCESS_NOISE_KEYS = ("process_noise_psd_m2_s3", "process_noise_psd_ric_m2_s3", "process_noise_accel_m_s2")
ONE_PROCESS_NOISE_CONVENTION = Rule(
    all_of(*(when(given(key), all_of(*(not_given(other) for other in PROCESS_NOISE_KEYS if other != key)))
             for key in PROCESS_NOISE_KEYS)),
    "give at most one of 'process_noise_psd_m2_s3' (PSD, m^2/s^3), 'process_noise_psd_ric_m2_s3' (a PSD per "
    "radial / in-track / cross-track axis, m^2/s^3) and 'process_noise_accel_m_s2' (per-step sigma_a, m/s^2), not "
    "both of any two")


def _has_boolean(value) -> bool:
    return isinstance(value, bool) or (isinstance(value, (list, tuple)) and any(isinstance(v, bool) for v in value))


def _numeric_only(annotation) -> bool:
    """Whether a field takes numbers (int, float, or tuples / lists of them, optionally None) and no boolean."""
    origin = typing.get_origin(annotation)
    if origin is Annotated:
        return _numeric_only(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        members = [a for a in typing.get_args(annotation) if a is not type(None)]
        return bool(members) and all(_numeric_only(a) for a in members)
    if origin in (tuple, list):
        members = [a for a in typing.get_args(annotation) if a is not Ellipsis]
        return bool(members) and all(_numeric_only(a) for a in members)
    return annotation in (int, float)


class StrictModel(BaseModel):
    # allow_inf_nan=False: every number in a scenario must be finite (.inf / .nan are refused, one line).
    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _reject_unknown_keys(cls, data):
        if isinstance(data, dict):
            allowed = set(cls.model_fields)
            unknown = sorted(str(k) for k in data if k not in allowed)
            if unknown:
                raise ValueError(
                    f"unknown key {unknown[0]!r}; allowed keys here: {', '.join(sorted(allowed))}"
                )
            for key, value in data.items():  # YAML's true / false is no number (pydantic would take it as 1 / 0)
                if _has_boolean(value) and _numeric_only(cls.model_fields[key].annotation):
                    raise ValueError(f"{key}: {str(value).lower()} is a boolean; allowed: a number")
        return data
