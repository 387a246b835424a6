"""Named families of symmetric periodic orbits: seeds, continuation limits, member lookup by period.

Halo classes follow the sign of z where the orbit crosses the x-z plane farthest from the x-y plane
(the apolune of an NRHO): `south` has z < 0 there. Turan et al. (2022) Table 1 orbits are both southern
(EML2: z = -0.0469 LU at the far crossing; EML1: -0.0371 LU), as 001 Appendix B calls its L1 halo.
Northern families are the mirror images (z -> -z), an exact symmetry of the CRTBP.
"""

from dataclasses import dataclass, replace

import numpy as np

from liaison_cli.dynamics.constants import LU_KM, MU, SECONDS_PER_DAY, TU_S
from liaison_cli.orbits.periodic import (
    MOON_RADIUS_KM,
    PeriodicOrbit,
    continue_family,
    correct,
    describe,
    lyapunov_guess,
)

TU_DAYS = TU_S / SECONDS_PER_DAY


class FamilyError(ValueError):
    """Unknown family, or a member outside the family's range."""


@dataclass(frozen=True)
class FamilySpec:
    name: str
    planar: bool
    description: str
    seed: tuple  # free variables X of a nearby guess
    seed_fixed: int  # index of X held fixed when correcting the seed
    direction: float  # +1 / -1: continuation direction in x0
    step: float
    min_period_days: float = 0.0
    max_period_days: float = 1e9
    min_perilune_km: float = MOON_RADIUS_KM + 100.0
    max_y_amplitude_lu: float = 0.6
    z_sign: float = 0.0  # spatial families: keep z0 on this side of the x-y plane
    both_ways: bool = True  # continue on both sides of the seed (False: the seed is one end)
    mirror_of: str | None = None

    def inside(self, orbit: PeriodicOrbit) -> bool:
        days = orbit.period_tu * TU_DAYS
        return (
            self.min_period_days <= days <= self.max_period_days
            and orbit.perilune_km >= self.min_perilune_km
            and orbit.y_amplitude_lu <= self.max_y_amplitude_lu
            and (self.z_sign == 0.0 or orbit.state[2] * self.z_sign > 1e-4)
        )


_L2_TABLE1 = (1.1785868, -0.0468605, -0.1673971, 1.6987)
# Table 1 EML1 stores the crossing nearer the x-y plane; the family keeps the other one (half a period on).
_L1_TABLE1 = (0.823510, -0.037090, 0.146410, 1.3760)
# 9:2 synodic-resonant L2 NRHO (apolune state, a published CRTBP value rounded to 4 digits)
_NRHO_9_2 = (1.0221, -0.1821, -0.1033, 0.7555)

_SOUTH = (
    FamilySpec("l2_halo_south", False, "EML2 southern halo, from the Lyapunov bifurcation to 8 d",
               _L2_TABLE1, 0, -1.0, 0.01, min_period_days=8.0, z_sign=-1.0),
    FamilySpec("l1_halo_south", False, "EML1 southern halo, from the Lyapunov bifurcation to 8 d",
               _L1_TABLE1, 0, 1.0, 0.01, min_period_days=8.0, z_sign=-1.0),
    FamilySpec("l2_nrho_south", False, "EML2 southern near-rectilinear halo, 8 d down to 2,000 km perilune",
               _NRHO_9_2, 0, -1.0, 0.005, max_period_days=8.0, min_perilune_km=2000.0, z_sign=-1.0),
)
FAMILIES: dict[str, FamilySpec] = {spec.name: spec for spec in _SOUTH}
for _spec in _SOUTH:
    _north = _spec.name.replace("_south", "_north")
    FAMILIES[_north] = replace(_spec, name=_north, description=_spec.description.replace("southern", "northern"),
                               seed=(_spec.seed[0], -_spec.seed[1], *_spec.seed[2:]), z_sign=-_spec.z_sign,
                               mirror_of=_spec.name)
for _point in (1, 2):
    FAMILIES[f"l{_point}_lyapunov"] = FamilySpec(
        f"l{_point}_lyapunov", True, f"EML{_point} planar Lyapunov, growing from a 2,000 km linear orbit",
        tuple(lyapunov_guess(_point, 2000.0 / LU_KM)), 0, -1.0 if _point == 1 else 1.0, 0.01,
        max_period_days=40.0, both_ways=False)
FAMILIES["dro"] = FamilySpec("dro", True, "Distant retrograde orbits about the Moon, periods 1 to 28 d",
                             (1.0 - MU + 10000.0 / LU_KM, -0.69, 0.08), 0, 1.0, 0.01, min_period_days=1.0,
                             max_period_days=28.0)


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
    """`count` members spread along the family (continuation order), each corrected and described."""
    spec = get_spec(name)
    if spec.mirror_of:
        return [_mirror(o) for o in generate_family(spec.mirror_of, count, mu)]
    X0, _ = correct(np.array(spec.seed), spec.planar, fixed=spec.seed_fixed, mu=mu)
    step = spec.step

    def keep_going(X):
        return spec.inside(describe(X, spec.planar, mu, samples=200))

    for _ in range(4):
        ahead = continue_family(X0, spec.planar, 100_000, step, spec.direction, keep_going, 4.0 * step, mu)
        behind = continue_family(X0, spec.planar, 100_000, step, -spec.direction, keep_going, 4.0 * step, mu) \
            if spec.both_ways else []
        members = behind[::-1] + ([X0] if keep_going(X0) else []) + ahead
        if len(members) >= count:
            break
        step /= 3.0
    if len(members) < count:
        raise FamilyError(f"family {name!r}: only {len(members)} members found, fewer than {count}")
    picks = np.unique(np.round(np.linspace(0, len(members) - 1, count)).astype(int))
    return [describe(members[i], spec.planar, mu) for i in picks]


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
    for i in _brackets(days, period_days):
        a, b = days[i], days[i + 1]
        w = 0.0 if a == b else (period_days - a) / (b - a)
        Xa, Xb = free_variables(members[i], spec.planar), free_variables(members[i + 1], spec.planar)
        guess = (1.0 - w) * Xa + w * Xb
        guess[-1] = period_days / TU_DAYS / 2.0
        X, _ = correct(guess, spec.planar, fixed=-1, mu=mu)
        return describe(X, spec.planar, mu)
    raise FamilyError(f"period_days = {period_days:g}: no bracketing members in family {name!r}")


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
