"""The period and amplitude range of each family's default 30-member table, as data.

Scenario validation checks a requested member against these numbers instead of generating or reading
the family on disk. `tests/unit/orbits/test_orbit_families.py` regenerates every family and checks that these
values are still the tables' minima and maxima (update them when a family's definition changes).
"""

# name: (min period_days, max period_days, min amplitude_km, max amplitude_km)
FAMILY_RANGES = {
    "dro": (1.001578914714134, 23.080190993816615, 10017.799553832854, 227874.80174597123),
    "l1_halo_north": (8.046936325363081, 12.104390394049066, 996.6101604742431, 78766.96514452393),
    "l1_halo_south": (8.046936325363081, 12.104390394049066, 996.6101604742431, 78766.96514452393),
    "l1_lyapunov": (11.715077508648324, 27.971174024629654, 7544.554134343557, 224791.9806544997),
    "l2_halo_north": (8.2965271632619, 14.831087796034637, 1809.549612617882, 77775.0877218723),
    "l2_halo_south": (8.2965271632619, 14.831087796034637, 1809.549612617882, 77775.0877218723),
    # The far end of l2_lyapunov depends on the numeric libraries' build: with the same code, one environment
    # ended at 30.0026 d / 226,538 km, this one (numpy 2.4, scipy 1.17) at 30.2137 d / 229,574 km (a
    # continuation step that flips); the README's 14.7-30.2 d is this one's.
    "l2_lyapunov": (14.64836700177855, 30.21370703370049, 652.7575152612001, 229574.5592724373),
    "l2_nrho_north": (6.079204513297212, 7.996597626306849, 67505.85537656785, 74951.69917217731),
    "l2_nrho_south": (6.079204513297212, 7.996597626306849, 67505.85537656785, 74951.69917217731),
}


def member_range(name: str, key: str) -> tuple[float, float]:
    """(low, high) of `period_days` or `amplitude_km` over the family's default table."""
    low_p, high_p, low_a, high_a = FAMILY_RANGES[name]
    return (low_p, high_p) if key == "period_days" else (low_a, high_a)
