"""Orbit-family tables on disk: generated once, then read from a user cache as Parquet.

Cache folder: `$LIAISON_ORBIT_CACHE_DIR`, else `$LIAISON_CACHE_DIR/families` (default
`~/.cache/liaison/families`). A file name carries
the family, the member count and a hash of the orbit and dynamics sources, so a changed corrector never
serves stale members.
"""

import dataclasses
import os
from functools import lru_cache
from pathlib import Path

import pandas as pd

from liaison_cli import __version__, core_source_hash, user_cache_dir
from liaison_cli.campaign.results import write_parquet_atomic
from liaison_cli.orbits.families import (
    TU_DAYS,
    amplitude_km,
    generate_family,
    get_spec,
    member_by_amplitude,
    member_by_period,
)
from liaison_cli.orbits.periodic import PeriodicOrbit

DEFAULT_COUNT = 30


def cache_dir() -> Path:
    if os.environ.get("LIAISON_ORBIT_CACHE_DIR"):
        return Path(os.environ["LIAISON_ORBIT_CACHE_DIR"])
    return Path(user_cache_dir()) / "families"


def family_path(name: str, count: int) -> Path:
    return cache_dir() / f"{name}-n{count}-{core_source_hash(('orbits', 'dynamics'))[:12]}.parquet"


def to_frame(name: str, members: list[PeriodicOrbit]) -> pd.DataFrame:
    rows = []
    for index, orbit in enumerate(members):
        row = {"family": name, "member": index}
        for axis, value in zip(("x", "y", "z", "vx", "vy", "vz"), orbit.state):
            row[f"{axis}0"] = value
        row.update({k: v for k, v in dataclasses.asdict(orbit).items() if k != "state"})
        row["period_days"] = orbit.period_tu * TU_DAYS
        row["amplitude_km"] = amplitude_km(orbit, get_spec(name).planar)
        rows.append(row)
    return pd.DataFrame(rows)


def from_frame(frame: pd.DataFrame) -> list[PeriodicOrbit]:
    fields = [f.name for f in dataclasses.fields(PeriodicOrbit) if f.name != "state"]  # extra columns ignored
    return [
        PeriodicOrbit(state=tuple(float(row[f"{a}0"]) for a in ("x", "y", "z", "vx", "vy", "vz")),
                      **{k: float(row[k]) for k in fields})
        for _, row in frame.iterrows()
    ]


def load_or_generate(name: str, count: int = DEFAULT_COUNT, regenerate: bool = False) -> tuple[pd.DataFrame, bool]:
    """(family table, read_from_cache)."""
    get_spec(name)
    path = family_path(name, count)
    if path.exists() and not regenerate:
        return pd.read_parquet(path), True
    spec = get_spec(name)
    if spec.mirror_of:  # z -> -z of the other class: no need to continue the family again
        base, _ = load_or_generate(spec.mirror_of, count, regenerate)
        frame = base.assign(family=name, z0=-base.z0, vz0=-base.vz0)
    else:
        frame = to_frame(name, generate_family(name, count))
    write_parquet_atomic(frame, path, {"package": "liaison", "package_version": __version__, "family": name,
                                       "count": count, "spec": repr(get_spec(name))})
    return frame, False


def cached_families() -> list[Path]:
    folder = cache_dir()
    return sorted(folder.glob("*.parquet")) if folder.exists() else []


@lru_cache(maxsize=64)
def member_state(name: str, period_days: float) -> PeriodicOrbit:
    """The family member with exactly this period (corrected), from the default-count table."""
    frame, _ = load_or_generate(name)
    return member_by_period(name, from_frame(frame), period_days)


@lru_cache(maxsize=64)
def member_by_amplitude_km(name: str, target_km: float) -> PeriodicOrbit:
    frame, _ = load_or_generate(name)
    return member_by_amplitude(name, from_frame(frame), target_km)
