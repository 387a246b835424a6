"""Named families of symmetric periodic orbits: seeds, stated ends, member lookup by period.

Each family ends at a stated rule: a range of its parameter (the period, or |z0| where the period turns
back along the family, as the L1 halo's does at 12.10 d), chosen inside the region the continuation
reaches on every machine tried. Where the walk itself stops (a step that collapses, a guard on perilune,
amplitude or the sign of z) hangs on the last bits of the arithmetic: one BLAS kernel ended l2_lyapunov at
30.00 d, another at 30.21 d. A family's table holds its members at equally spaced values of the parameter
between the ends, each corrected with that value held fixed, so the table does not depend on how the walk
stepped. Where two members share a period (the L1 halo between 11.91 and 12.10 d), a period names the
first in table order, the one of smaller amplitude. The tables that scenarios use ship with the package
(orbits.family_catalogue).

Halo classes follow the sign of z where the orbit crosses the x-z plane farthest from the x-y plane
(the apolune of an NRHO): `south` has z < 0 there. Turan et al. (2022) Table 1 orbits are both southern
(EML2: z = -0.0469 LU at the far crossing; EML1: -0.0371 LU), as 001 Appendix B calls its L1 halo.
Northern families are the mirror images (z -> -z), an exact symmetry of the CRTBP.
"""

from dataclasses import dataclass, replace

import numpy as np

from liaison_cli.dynamics.constants import LU_KM, MU, SECONDS_PER_DAY, TU_S
from liaison_cli.errors import LiaisonError
from liaison_cli.orbits.periodic import (
    MOON_RADIUS_KM,
    CorrectionError,
    PeriodicOrbit,
    continue_family,
    correct,
    describe,
    lyapunov_guess,
)

TU_DAYS = TU_S / SECONDS_PER_DAY


class FamilyError(LiaisonError, ValueError):
    """Unknown family, a member outside the family's range, or a family that cannot be generated (exit 2)."""


PERIOD = "period_days"  # a family parameter: the period, days
Z_AMPLITUDE = "z0_km"  # a family parameter: |z0| at the far x-z crossing, km (spatial families)
# How far past each end the walk goes, so that the end member lies between two walked members.
WALK_MARGIN = {PERIOD: 0.5, Z_AMPLITUDE: 2000.0}


@dataclass(frozen=True)
class FamilySpec:
    name: str
    planar: bool
    description: str
    seed: tuple  # free variables X of a nearby guess
    seed_fixed: int  # index of X held fixed when correcting the seed
    direction: float  # +1 / -1: continuation direction in x0
    step: float
    ends: tuple  # (low, high) of `parameter`: the family's stated range
    parameter: str = PERIOD
    min_perilune_km: float = MOON_RADIUS_KM + 100.0
    max_y_amplitude_lu: float = 0.6
    z_sign: float = 0.0  # spatial families: keep z0 on this side of the x-y plane
    both_ways: bool = True  # continue on both sides of the seed (False: only along `direction`)
    mirror_of: str | None = None

    def value(self, X) -> float:
        """The family parameter of free variables X."""
        return 2.0 * X[-1] * TU_DAYS if self.parameter == PERIOD else abs(X[1]) * LU_KM

    def free_variables_at(self, guess, value: float) -> tuple[np.ndarray, int]:
        """(guess with the parameter set to `value`, the index of X to hold fixed while correcting)."""
        X = np.array(guess, dtype=float)
        if self.parameter == PERIOD:
            X[-1] = value / TU_DAYS / 2.0
            return X, -1
        X[1] = np.copysign(value / LU_KM, X[1])
        return X, 1

    def walkable(self, orbit: PeriodicOrbit) -> bool:
        """The continuation walks on while the guards hold and the parameter is within WALK_MARGIN of the ends."""
        margin = WALK_MARGIN[self.parameter]
        X = free_variables(orbit, self.planar)
        return (
            self.ends[0] - margin <= self.value(X) <= self.ends[1] + margin
            and orbit.perilune_km >= self.min_perilune_km
            and orbit.y_amplitude_lu <= self.max_y_amplitude_lu
            and (self.z_sign == 0.0 or orbit.state[2] * self.z_sign > 1e-4)
        )


_L2_TABLE1 = (1.1785868, -0.0468605, -0.1673971, 1.6987)
# Table 1 EML1 stores the crossing nearer the x-y plane; the family keeps the other one (half a period on).
_L1_TABLE1 = (0.823510, -0.037090, 0.146410, 1.3760)
# 9:2 synodic-resonant L2 NRHO (apolune state, a published CRTBP value rounded to 4 digits)
_NRHO_9_2 = (1.0221, -0.1821, -0.1033, 0.7555)

# The ends, inside what the walk reaches on every kernel tried (where it stops by itself, in brackets):
# l2 halo 8.5-14.8 d (8.30 d, a collapsing step; 14.83 d, z -> 0 at the Lyapunov bifurcation); l1 halo
# |z0| 2,000-78,000 km, 11.92 to 12.10 and back to 8.2 d (1,100 km at the bifurcation); NRHO 6.2-8 d (6.10 d,
# the 2,000 km perilune guard); l1 / l2 Lyapunov 12-26 / 15-28 d (walked from a 2,000 km orbit whose period
# first dips; 27.3 / 29.3 d, the 0.6 LU y-amplitude guard); DRO 1-22 d (22.45 d, the same guard).
_SOUTH = (
    FamilySpec("l2_halo_south", False, "EML2 southern halo, periods 8.5 to 14.8 d (the Lyapunov bifurcation)",
               _L2_TABLE1, 0, -1.0, 0.01, ends=(8.5, 14.8), z_sign=-1.0),
    FamilySpec("l1_halo_south", False, "EML1 southern halo, Az 2,000 to 78,000 km (periods 8.2 to 12.1 d)",
               _L1_TABLE1, 0, 1.0, 0.01, ends=(2000.0, 78000.0), parameter=Z_AMPLITUDE, z_sign=-1.0),
    FamilySpec("l2_nrho_south", False, "EML2 southern near-rectilinear halo, periods 6.2 to 8 d",
               _NRHO_9_2, 0, -1.0, 0.005, ends=(6.2, 8.0), min_perilune_km=2000.0, z_sign=-1.0),
)
FAMILIES: dict[str, FamilySpec] = {spec.name: spec for spec in _SOUTH}
for _spec in _SOUTH:
    _north = _spec.name.replace("_south", "_north")
    FAMILIES[_north] = replace(_spec, name=_north, description=_spec.description.replace("southern", "northern"),
                               seed=(_spec.seed[0], -_spec.seed[1], *_spec.seed[2:]), z_sign=-_spec.z_sign,
                               mirror_of=_spec.name)
for _point, _ends in ((1, (12.0, 26.0)), (2, (15.0, 28.0))):
    FAMILIES[f"l{_point}_lyapunov"] = FamilySpec(
        f"l{_point}_lyapunov", True, f"EML{_point} planar Lyapunov, periods {_ends[0]:g} to {_ends[1]:g} d (walked "
        "from a 2,000 km linear orbit)", tuple(lyapunov_guess(_point, 2000.0 / LU_KM)), 0, -1.0 if _point == 1 else 1.0,
        0.01, ends=_ends, both_ways=False)
FAMILIES["dro"] = FamilySpec("dro", True, "Distant retrograde orbits about the Moon, periods 1 to 22 d",
                             (1.0 - MU + 10000.0 / LU_KM, -0.69, 0.08), 0, 1.0, 0.01, ends=(1.0, 22.0))


def family_names() -> list[str]:
    return sorted(FAMILIES)


def get_spec(name: str) -> FamilySpec:
    if name not in FAMILIES:
        raise FamilyError(f"unknown orbit family {name!r}; known: {', '.join(family_names())}")
    return FAMILIES[name]


def _mirror(orbit: PeriodicOrbit) -> PeriodicOrbit:
    s = orbit.state
    return replace(orbit, state=(s[0], s[1], -s[2], s[3], s[4], s[5]))


def free_variables(orbit: PeriodicOrbit, planar: bool) -> np.ndarray:
    s = orbit.state
    half = orbit.period_tu / 2.0
    return np.array([s[0], s[4], half]) if planar else np.array([s[0], s[2], s[4], half])


def generate_family(name: str, count: int, mu: float = MU) -> list[PeriodicOrbit]:
    """`count` members at equally spaced values of the family parameter between its ends, each corrected
    with that value held fixed, then described. Walks the family first (pseudo-arclength continuation past
    both ends); a walk too coarse to correct every member from is repeated with a step a third as long (up
    to three times)."""
    spec = get_spec(name)
    if spec.mirror_of:
        return [_mirror(o) for o in generate_family(spec.mirror_of, count, mu)]
    X0, _ = correct(np.array(spec.seed), spec.planar, fixed=spec.seed_fixed, mu=mu)
    step = spec.step
    for attempt in range(4):
        walked = _walk(spec, X0, step, mu)
        _check_walk(spec, walked)
        try:
            return [describe(_corrected_at(spec, walked, value, mu), spec.planar, mu)
                    for value in np.linspace(*spec.ends, count)]
        except CorrectionError:
            if attempt == 3:
                raise FamilyError(f"family {name!r}: a member between {spec.ends[0]:g} and {spec.ends[1]:g} "
                                  f"{spec.parameter} did not correct from walks with steps down to {step:g}") from None
            step /= 3.0


def _walk(spec: FamilySpec, X0, step: float, mu: float) -> list[np.ndarray]:
    """The corrected free variables of the walked members, in family order (the seed among them)."""

    def keep_going(X):
        return spec.walkable(describe(X, spec.planar, mu, samples=200))

    ahead = continue_family(X0, spec.planar, 100_000, step, spec.direction, keep_going, 4.0 * step, mu)
    behind = continue_family(X0, spec.planar, 100_000, step, -spec.direction, keep_going, 4.0 * step, mu) \
        if spec.both_ways else []
    return behind[::-1] + [np.asarray(X0, dtype=float)] + ahead


def _check_walk(spec: FamilySpec, walked) -> None:
    """Refuse (FamilyError) a walk that did not reach past both ends, or along which the parameter is not
    monotonic between them (a member would then not be named by its value alone)."""
    values = np.array([spec.value(X) for X in walked])
    low, high = spec.ends
    if not (values.min() <= low and high <= values.max()):
        raise FamilyError(f"family {spec.name!r}: the continuation covered {spec.parameter} {values.min():.6g} to "
                          f"{values.max():.6g}, not its stated range {low:g} to {high:g}")
    inner = np.flatnonzero((values >= low) & (values <= high))
    steps = np.diff(values[max(inner[0] - 1, 0) : inner[-1] + 2])
    if not (np.all(steps > 0) or np.all(steps < 0)):
        raise FamilyError(f"family {spec.name!r}: {spec.parameter} is not monotonic between {low:g} and {high:g}")


def _corrected_at(spec: FamilySpec, walked, value: float, mu: float, by=None) -> np.ndarray:
    """Free variables of the member whose parameter (or, with `by` = PERIOD, period) is `value`:
    interpolated between the first bracketing pair of walked members, then corrected with it held fixed."""
    by = by or spec.parameter
    probe = spec if by == spec.parameter else replace(spec, parameter=by)
    values = np.array([probe.value(X) for X in walked])
    for i in _brackets(values, value):
        a, b = values[i], values[i + 1]
        w = 0.0 if a == b else (value - a) / (b - a)
        guess, fixed = probe.free_variables_at((1.0 - w) * walked[i] + w * walked[i + 1], value)
        return correct(guess, spec.planar, fixed=fixed, mu=mu)[0]
    raise FamilyError(f"{by} = {value:g}: no bracketing members in family {spec.name!r}")


def _brackets(values: np.ndarray, target: float):
    """Indices i (in family order) with target between values[i] and values[i + 1]."""
    for i in range(len(values) - 1):
        if min(values[i], values[i + 1]) <= target <= max(values[i], values[i + 1]):
            yield i


def member_by_period(name: str, members: list[PeriodicOrbit], period_days: float, mu: float = MU) -> PeriodicOrbit:
    """The member with exactly this period: interpolate between the first bracketing pair, then correct
    with the period held fixed."""
    spec = get_spec(name)
    days = np.array([m.period_tu * TU_DAYS for m in members])
    lo, hi = float(days.min()), float(days.max())
    if not lo <= period_days <= hi:
        raise FamilyError(f"period_days = {period_days:g} is outside family {name!r}: valid {lo:.3f} to {hi:.3f} days")
    walked = [free_variables(m, spec.planar) for m in members]
    return describe(_corrected_at(spec, walked, period_days, mu, by=PERIOD), spec.planar, mu)


def amplitude_km(orbit: PeriodicOrbit, planar: bool) -> float:
    """The amplitude that names a member: Az (max |z|) for spatial families, Ay for planar ones."""
    return (orbit.y_amplitude_lu if planar else orbit.z_amplitude_lu) * LU_KM


def member_by_amplitude(name: str, members: list[PeriodicOrbit], target_km: float, mu: float = MU) -> PeriodicOrbit:
    """The member with this amplitude: secant iterations on the period between the first bracketing pair."""
    spec = get_spec(name)
    amps = np.array([amplitude_km(m, spec.planar) for m in members])
    days = np.array([m.period_tu * TU_DAYS for m in members])
    lo, hi = float(amps.min()), float(amps.max())
    if not lo <= target_km <= hi:
        raise FamilyError(f"amplitude_km = {target_km:g} is outside family {name!r}: valid {lo:.0f} to {hi:.0f} km")
    for i in _brackets(amps, target_km):
        a, b = amps[i], amps[i + 1]
        p0, p1, f0, f1 = days[i], days[i + 1], a - target_km, b - target_km
        if f0 == 0.0:
            return members[i]
        orbit = members[i + 1]
        for _ in range(30):
            if abs(f1) < 1e-3 or p1 == p0:
                return orbit
            p2 = p1 - f1 * (p1 - p0) / (f1 - f0)
            lo_p, hi_p = min(days[i], days[i + 1]), max(days[i], days[i + 1])
            p2 = min(max(p2, lo_p), hi_p)
            orbit = member_by_period(name, members[i : i + 2], p2, mu)
            p0, f0, p1, f1 = p1, f1, p2, amplitude_km(orbit, spec.planar) - target_km
        return orbit
    raise FamilyError(f"amplitude_km = {target_km:g}: no bracketing members in family {name!r}")
