"""Orbit-family tables on disk: generated once, then read from a user cache (NumPy .npz, no pickles).

Cache folder: `$LIAISON_ORBIT_CACHE_DIR`, else `$LIAISON_CACHE_DIR/families` (default
`~/.cache/liaison/families`). A file name carries the family, the member count and a hash of the orbit
and dynamics sources, so a changed corrector never serves stale members.
"""

import dataclasses
import os
from collections import namedtuple
from functools import lru_cache
from pathlib import Path

import numpy as np

from liaison_cli import core_source_hash
from liaison_cli.orbits.families import (
    TU_DAYS,
    amplitude_km,
    generate_family,
    get_spec,
    member_by_amplitude,
    member_by_period,
)
from liaison_cli.orbits.npz_cache import cache_folder, read_intact, write_npz
from liaison_cli.orbits.periodic import PeriodicOrbit

DEFAULT_COUNT = 30
AXES = ("x", "y", "z", "vx", "vy", "vz")


class FamilyTable:
    """Column table of a family: `table.period_days`, `table["period_days"]`, `len(table)`,
    `table.itertuples()` (one namedtuple per member, in member order)."""

    def __init__(self, columns: dict):
        self.columns = {name: np.asarray(values) for name, values in columns.items()}

    def __getitem__(self, name):
        return self.columns[name]

    def __getattr__(self, name):
        try:
            return self.__dict__["columns"][name]
        except KeyError:
            raise AttributeError(name) from None

    def __len__(self):
        return len(self.columns["member"])

    def itertuples(self):
        row = namedtuple("Member", list(self.columns))
        for i in range(len(self)):
            yield row(*(values[i] for values in self.columns.values()))

    def with_columns(self, **changes) -> "FamilyTable":
        return FamilyTable({**self.columns, **changes})


def cache_dir() -> Path:
    if os.environ.get("LIAISON_ORBIT_CACHE_DIR"):
        return Path(os.environ["LIAISON_ORBIT_CACHE_DIR"])
    return cache_folder("families")


def family_path(name: str, count: int) -> Path:
    return cache_dir() / f"{name}-n{count}-{core_source_hash(('orbits', 'dynamics'))[:12]}.npz"


def to_table(name: str, members: list[PeriodicOrbit]) -> FamilyTable:
    planar = get_spec(name).planar
    columns = {"family": np.array([name] * len(members)), "member": np.arange(len(members))}
    for i, axis in enumerate(AXES):
        columns[f"{axis}0"] = np.array([orbit.state[i] for orbit in members])
    for field in dataclasses.fields(PeriodicOrbit):
        if field.name != "state":
            columns[field.name] = np.array([getattr(orbit, field.name) for orbit in members], dtype=float)
    columns["period_days"] = np.array([orbit.period_tu * TU_DAYS for orbit in members])
    columns["amplitude_km"] = np.array([amplitude_km(orbit, planar) for orbit in members])
    return FamilyTable(columns)


def from_table(table: FamilyTable) -> list[PeriodicOrbit]:
    fields = [f.name for f in dataclasses.fields(PeriodicOrbit) if f.name != "state"]
    return [
        PeriodicOrbit(state=tuple(float(table[f"{a}0"][i]) for a in AXES), **{k: float(table[k][i]) for k in fields})
        for i in range(len(table))
    ]


def _save(table: FamilyTable, path: Path) -> None:
    write_npz(table.columns, path)


def _load(path: Path) -> FamilyTable:
    with np.load(path, allow_pickle=False) as data:
        return FamilyTable({name: data[name] for name in data.files})


def _required_columns() -> list[str]:
    fields = [f.name for f in dataclasses.fields(PeriodicOrbit) if f.name != "state"]
    return ["family", "member", *(f"{a}0" for a in AXES), *fields, "period_days", "amplitude_km"]


def _load_intact(path: Path, name: str, count: int) -> FamilyTable | None:
    """The cached table, or None (with a note on stderr) when the file is damaged: not a readable .npz
    (truncated, overwritten: BadZipFile, EOFError, ValueError, ...), or columns missing, of unequal
    lengths or not numbers. The cache is derived data, so the caller rebuilds it."""
    return read_intact(path, _read_checked, "orbit-family", f"rebuilding it (as 'liaison orbits generate {name} "
                       f"--count {count} --regenerate' does)")


def _read_checked(path: Path) -> tuple[FamilyTable, str | None]:
    table = _load(path)
    columns = _required_columns()
    present = all(c in table.columns for c in columns)
    lengths = {len(table.columns[c]) for c in columns} if present else set()
    intact = len(lengths) == 1 and lengths != {0} and all(table.columns[c].dtype.kind == "f" for c in columns[2:])
    return table, None if intact else "missing or malformed columns"


def load_or_generate(name: str, count: int = DEFAULT_COUNT, regenerate: bool = False) -> tuple[FamilyTable, bool]:
    """(family table, read_from_cache). A damaged cache file is rebuilt (one note on stderr)."""
    spec = get_spec(name)
    path = family_path(name, count)
    if path.exists() and not regenerate:
        table = _load_intact(path, name, count)
        if table is not None:
            return table, True
    if spec.mirror_of:  # z -> -z of the other class: no need to continue the family again
        base, _ = load_or_generate(spec.mirror_of, count, regenerate)
        table = base.with_columns(family=np.array([name] * len(base)), z0=-base.z0, vz0=-base.vz0)
    else:
        table = to_table(name, generate_family(name, count))
    _save(table, path)
    return table, False


def cached_families() -> list[Path]:
    folder = cache_dir()
    return sorted(folder.glob("*.npz")) if folder.exists() else []


@lru_cache(maxsize=64)
def member_state(name: str, period_days: float) -> PeriodicOrbit:
    """The family member with exactly this period (corrected), from the default-count table."""
    table, _ = load_or_generate(name)
    return member_by_period(name, from_table(table), period_days)


@lru_cache(maxsize=64)
def member_by_amplitude_km(name: str, target_km: float) -> PeriodicOrbit:
    table, _ = load_or_generate(name)
    return member_by_amplitude(name, from_table(table), target_km)
