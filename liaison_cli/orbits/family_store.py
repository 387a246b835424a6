"""Orbit-family tables: the shipped catalogue's (orbits.family_catalogue) for the default 30 members, any
other count generated once, then read from a user cache (NumPy .npz, no pickles); members by period or
amplitude.

Cache folder: `$LIAISON_ORBIT_CACHE_DIR`, else `$LIAISON_CACHE_DIR/families` (default
`~/.cache/liaison/families`). A file name carries the family, the member count and a hash of the orbit
and dynamics sources, so a changed corrector never serves stale members.
"""

import os
from functools import lru_cache
from pathlib import Path

import numpy as np

from liaison_cli import core_source_hash
from liaison_cli.orbits.families import generate_family, get_spec, member_by_amplitude, member_by_period
from liaison_cli.orbits.family_catalogue import CATALOGUE_COUNT, shipped_table
from liaison_cli.orbits.family_table import FamilyTable, from_table, mirrored, required_columns, to_table
from liaison_cli.orbits.npz_cache import cache_folder, read_intact, write_npz
from liaison_cli.orbits.periodic import PeriodicOrbit

DEFAULT_COUNT = CATALOGUE_COUNT


def family_tables_dir() -> Path:
    if os.environ.get("LIAISON_ORBIT_CACHE_DIR"):
        return Path(os.environ["LIAISON_ORBIT_CACHE_DIR"])
    return cache_folder("families")


def family_path(name: str, count: int) -> Path:
    return family_tables_dir() / f"{name}-n{count}-{core_source_hash(('orbits', 'dynamics'))[:12]}.npz"


def _save(table: FamilyTable, path: Path) -> None:
    write_npz(table.columns, path)


def _load(path: Path) -> FamilyTable:
    with np.load(path, allow_pickle=False) as data:
        return FamilyTable({name: data[name] for name in data.files})


def _load_intact(path: Path, name: str, count: int) -> FamilyTable | None:
    """The cached table, or None (with a note on stderr) when the file is damaged: not a readable .npz
    (truncated, overwritten: BadZipFile, EOFError, ValueError, ...), or columns missing, of unequal
    lengths or not numbers. The cache is derived data, so the caller rebuilds it."""
    return read_intact(path, _read_checked, "orbit-family", f"rebuilding it (as 'liaison orbits generate {name} "
                       f"--count {count} --regenerate' does)")


def _read_checked(path: Path) -> tuple[FamilyTable, str | None]:
    table = _load(path)
    columns = required_columns()
    present = all(c in table.columns for c in columns)
    lengths = {len(table.columns[c]) for c in columns} if present else set()
    intact = len(lengths) == 1 and lengths != {0} and all(table.columns[c].dtype.kind == "f" for c in columns[2:])
    return table, None if intact else "missing or malformed columns"


def load_or_generate(name: str, count: int = DEFAULT_COUNT, regenerate: bool = False) -> tuple[FamilyTable, bool]:
    """(family table, read_from_disk). The default count is the shipped catalogue's table (the same on every
    machine); another count, or `regenerate`, is generated into the user cache (a damaged cache file is
    rebuilt, with one note on stderr)."""
    spec = get_spec(name)
    if count == CATALOGUE_COUNT and not regenerate:
        return shipped_table(name), True
    path = family_path(name, count)
    if path.exists() and not regenerate:
        table = _load_intact(path, name, count)
        if table is not None:
            return table, True
    if spec.mirror_of:  # z -> -z of the other class: no need to continue the family again
        base, _ = load_or_generate(spec.mirror_of, count, regenerate)
        table = mirrored(base, name)
    else:
        table = to_table(name, generate_family(name, count))
    _save(table, path)
    return table, False


def cached_families() -> list[Path]:
    folder = family_tables_dir()
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
