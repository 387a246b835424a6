"""A family's members as a column table (`FamilyTable`), and the conversions to and from `PeriodicOrbit`s."""

import dataclasses
from collections import namedtuple

import numpy as np

from liaison_cli.orbits.families import TU_DAYS, amplitude_km, get_spec
from liaison_cli.orbits.periodic import PeriodicOrbit

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


def required_columns() -> list[str]:
    """Every column of a family table, in order: family, member, the initial state, the orbit's properties."""
    fields = [f.name for f in dataclasses.fields(PeriodicOrbit) if f.name != "state"]
    return ["family", "member", *(f"{a}0" for a in AXES), *fields, "period_days", "amplitude_km"]


def mirrored(table: FamilyTable, name: str) -> FamilyTable:
    """The z -> -z image of a family table (an exact symmetry of the CRTBP), named `name`."""
    return table.with_columns(family=np.array([name] * len(table)), z0=-table.z0, vz0=-table.vz0)
