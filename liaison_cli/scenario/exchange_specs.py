"""The scenario keys that bring CCSDS files in (docs/exchange.md): a spacecraft's `orbit: {oem: FILE}` or
`orbit: {opm: FILE}` (dated scenarios), and `measurements: {tdm: FILE}`. A FILE is absolute or relative to the
scenario file's folder (resolve_exchange_files, called when the scenario is read). The files' contents are
checked when the scenario is set up (scenario.orbit_files, scenario.observed)."""

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, model_validator

ORBIT_FILE_KINDS = ("oem", "opm")


class _FileSpec(BaseModel):
    """Frozen, and an unknown key is named with the keys allowed (as schema.StrictModel does)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    @model_validator(mode="before")
    @classmethod
    def _known_keys(cls, data):
        if isinstance(data, dict):
            unknown = sorted(str(k) for k in data if k not in cls.model_fields)
            if unknown:
                raise ValueError(f"unknown key {unknown[0]!r}; allowed keys here: {', '.join(sorted(cls.model_fields))}")
        return data


class OrbitFileSpec(_FileSpec):
    """A spacecraft's truth from an OEM (interpolated as its INTERPOLATION says), or its initial state from an
    OPM (then propagated by the scenario's dynamics)."""

    oem: str | None = Field(None, description="an OEM file (KVN or XML): the truth follows it")
    opm: str | None = Field(None, description="an OPM file (KVN or XML): the initial state at the scenario epoch")
    object_name: str | None = Field(None, description="the file's OBJECT_NAME to use; default: the spacecraft's "
                                    "name, or the file's only object")

    @model_validator(mode="after")
    def _one_file(self):
        if (self.oem is None) == (self.opm is None):
            raise ValueError("give exactly one of 'oem' or 'opm'")
        return self

    @property
    def kind(self) -> str:
        return "oem" if self.oem is not None else "opm"

    @property
    def path(self) -> str:
        return self.oem if self.oem is not None else self.opm


class MeasurementFileSpec(_FileSpec):
    """The filter's measurements from a TDM instead of simulated ones: one run; its initial error (and any
    other draw: clocks, biases, C_R) is run `run`'s of the scenario seed, so a TDM exported from run K and
    read back with run: K gives that run's estimate."""

    tdm: str = Field(description="a TDM file (KVN or XML)")
    run: int = Field(0, ge=0, description="the run whose draws (initial error, clocks, biases) the filter takes "
                     "(run index)")


def orbit_file_from_mapping(data):
    """SpacecraftSpec's reading of `orbit: {oem: FILE}`: orbit becomes 'oem' (or 'opm') and the mapping goes to
    `orbit_file`."""
    if isinstance(data, dict) and isinstance(data.get("orbit"), dict):
        data = dict(data)
        given = [k for k in ORBIT_FILE_KINDS if k in data["orbit"]]
        data["orbit_file"] = data["orbit"]
        data["orbit"] = given[0] if len(given) == 1 else "oem"
    return data


def _resolved(path, folder: Path):
    return path if not isinstance(path, str) or Path(path).is_absolute() else str((folder / path).resolve())


def resolve_exchange_files(data, folder: Path):
    """The scenario mapping with its CCSDS file paths made absolute against `folder` (the scenario's)."""
    if not isinstance(data, dict):
        return data
    data = dict(data)
    if isinstance(data.get("measurements"), dict):
        data["measurements"] = {**data["measurements"], "tdm": _resolved(data["measurements"].get("tdm"), folder)}
    if isinstance(data.get("spacecraft"), list):
        spacecraft = []
        for sc in data["spacecraft"]:
            if isinstance(sc, dict) and isinstance(sc.get("orbit"), dict):
                sc = {**sc, "orbit": {k: _resolved(v, folder) if k in ORBIT_FILE_KINDS else v
                                      for k, v in sc["orbit"].items()}}
            spacecraft.append(sc)
        data["spacecraft"] = spacecraft
    return data


def orbit_json_schema(schema: dict, names: list) -> None:
    """SpacecraftSpec.orbit in the JSON Schema: one of `names`, or the {oem: FILE} / {opm: FILE} mapping the
    loader moves into orbit_file."""
    schema.pop("type", None)
    mapping = OrbitFileSpec.model_json_schema()
    mapping.pop("title", None)
    schema["anyOf"] = [{"type": "string", "enum": names}, mapping]
