"""Typed errors. The CLI maps each to an exit code and prints its one-line message; nothing else does."""


class LiaisonError(Exception):
    """A user-facing problem with clear wording; exit code 2 (bad input or usage)."""

    exit_code = 2


class ScenarioError(LiaisonError):
    """The scenario file cannot be read or does not satisfy the schema."""


class OrbitCorrectionError(LiaisonError):
    """A reference orbit could not be corrected into the dated model (multiple shooting did not converge)."""


class OutputExistsError(LiaisonError):
    """The output directory exists and --overwrite was not given."""


class UnreadableFileError(LiaisonError):
    """A file liaison should read is corrupt or not what it claims to be (e.g. a damaged Parquet table)."""

    exit_code = 4


class ExchangeFileError(LiaisonError):
    """A CCSDS file (OEM, OPM, TDM) cannot be used: malformed, of another type, in an unsupported frame or time
    system, not covering the scenario, or naming a participant the scenario lacks; or the library is missing."""
