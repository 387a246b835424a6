"""The shipped orbit catalogue: every family's 30-member table as data (orbits/data/family_catalogue.npz),
so every machine flies the same orbits and a first run generates nothing.

A member lookup (orbits.family_store.member_state) corrects the orbit with the requested period from the
two catalogue members around it, so the catalogue fixes the seeds of those corrections and the ranges that
`validate` and `run` accept (`member_range`), both the same everywhere. Northern classes are derived from the
southern ones (z -> -z). `liaison orbits catalogue` regenerates the file (`build_catalogue`); the test suite
regenerates every family and compares it with the shipped one (tests/unit/orbits/test_family_catalogue.py).
The file (NumPy .npz, no pickles: orbits/ stays free of text-format libraries) holds each column as
`<family>/<column>`, each family's generation settings (seed, step, parameter and ends) as the text of a
Python literal in `<family>/settings`, and in `about` the corrector's tolerances and the arithmetic it was
generated with; float64 arrays, so reading gives back the generated values bit for bit.
"""

import ast
import dataclasses
import io
from functools import cache
from pathlib import Path

import numpy as np

from liaison_cli import __version__
from liaison_cli.orbits.families import FAMILIES, FamilyError, generate_family, get_spec
from liaison_cli.orbits.family_table import AXES, FamilyTable, mirrored, to_table
from liaison_cli.orbits.periodic import ATOL, RTOL

CATALOGUE_PATH = Path(__file__).with_name("data") / "family_catalogue.npz"
CATALOGUE_FORMAT = 1
CATALOGUE_COUNT = 30
CORRECTOR_TOLERANCE_LU = 1e-12  # orbits.periodic.correct's default: |F| of a corrected member


def generated_families() -> list[str]:
    """The families the catalogue holds tables of (the others are their mirror images)."""
    return sorted(name for name, spec in FAMILIES.items() if spec.mirror_of is None)


def build_catalogue(names=None) -> dict:
    """The catalogue as a dict: "about" (format, count, tolerances, arithmetic) and "families" (name ->
    {"settings": the FamilySpec's fields, "columns": name -> array}) for each named (default: every
    generated) family."""
    from liaison_cli.provenance import arithmetic_provenance

    families = {}
    for name in names or generated_families():
        table = to_table(name, generate_family(name, CATALOGUE_COUNT))
        settings = {key: _plain(value) for key, value in dataclasses.asdict(get_spec(name)).items()}
        families[name] = {"settings": settings, "columns": table.columns}
    about = {"format": CATALOGUE_FORMAT, "generated_by": "liaison orbits catalogue", "liaison_version": __version__,
             "count": CATALOGUE_COUNT, "propagation": {"rtol": RTOL, "atol": ATOL},
             "corrector_tolerance_lu": CORRECTOR_TOLERANCE_LU, "arithmetic": arithmetic_provenance()}
    return {**about, "families": families}


def _plain(value):
    """Python floats for numpy scalars (also inside tuples), so the settings' text is a plain literal."""
    if isinstance(value, (tuple, list)):
        return tuple(_plain(v) for v in value)
    return float(value) if isinstance(value, np.floating) else value


def write_catalogue(catalogue: dict, path: Path = CATALOGUE_PATH) -> Path:
    from liaison_cli.storage import write_bytes_atomic

    about = {key: value for key, value in catalogue.items() if key != "families"}
    arrays = {"about": np.array(repr(about))}
    for name, entry in catalogue["families"].items():
        arrays[f"{name}/settings"] = np.array(repr(entry["settings"]))
        arrays.update({f"{name}/{column}": values for column, values in entry["columns"].items()})
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    write_bytes_atomic(buffer.getvalue(), path)
    return path


@cache
def read_catalogue(path: Path = CATALOGUE_PATH) -> dict:
    """The shipped catalogue, read once per process, in build_catalogue's shape."""
    with np.load(path, allow_pickle=False) as data:
        catalogue = ast.literal_eval(str(data["about"]))
        families: dict = {}
        for key in data.files:
            name, _, column = key.partition("/")
            if column == "settings":
                families.setdefault(name, {"columns": {}})["settings"] = ast.literal_eval(str(data[key]))
            elif column:
                families.setdefault(name, {"columns": {}})["columns"][column] = data[key]
    if catalogue.get("format") != CATALOGUE_FORMAT:
        raise FamilyError(f"{path}: orbit catalogue format {catalogue.get('format')!r}, this liaison reads "
                          f"{CATALOGUE_FORMAT}; reinstall liaison")
    return {**catalogue, "families": families}


def table_from_catalogue(catalogue: dict, name: str) -> FamilyTable:
    """Family `name` (a mirrored class too) from a catalogue dict."""
    spec = get_spec(name)
    base = spec.mirror_of or name
    entry = catalogue["families"].get(base)
    if entry is None:
        raise FamilyError(f"family {name!r} is not in the orbit catalogue; regenerate it (liaison orbits catalogue)")
    table = FamilyTable(dict(entry["columns"]))
    return mirrored(table, name) if spec.mirror_of else table


@cache
def shipped_table(name: str) -> FamilyTable:
    return table_from_catalogue(read_catalogue(), name)


def member_range(name: str, key: str) -> tuple[float, float]:
    """(low, high) of `period_days` or `amplitude_km` over the family's shipped table: what `validate` and
    `run` accept."""
    column = shipped_table(name)[key]
    return float(column.min()), float(column.max())


def largest_change(catalogue: dict, shipped: dict | None = None) -> dict[str, float]:
    """Per family: the largest |difference| of an initial-state component (LU, LU/TU) between `catalogue`
    and the shipped one (inf where the tables differ in shape or a family is new)."""
    shipped = shipped or read_catalogue()
    changes = {}
    for name, entry in catalogue["families"].items():
        old = shipped["families"].get(name)
        states = [np.array([entry_["columns"][f"{axis}0"] for axis in AXES]) if entry_ else None
                  for entry_ in (entry, old)]
        same_shape = states[1] is not None and states[0].shape == states[1].shape
        changes[name] = float(np.max(np.abs(states[0] - states[1]))) if same_shape else float("inf")
    return changes
