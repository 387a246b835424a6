"""The dated model's lunar orientation against DE421's integrated librations: writes
results/reference/lunar_orientation.md.

`python -m benchmarks.lunar_orientation` compares the rotation liaison turns GRGM1200A with
(dynamics.lunar_orientation: the IAU WGCCRE series for the mean-Earth axes, then DE430's constant turn to the
principal axes) with the principal-axes frame of DE421's numerically integrated physical librations, the ephemeris
whose bodies the dated model flies. The librations come from the `de421` package on PyPI (Brandon Rhodes, MIT; a
test dependency): three Euler angles (phi, theta, psi) per 8-day Chebyshev interval, r_PA = Rz(psi) Rx(theta)
Rz(phi) r_ICRF, TDB. `departures` and `de421_pa_from_icrf` are the test's reference too
(tests/unit/dynamics/test_lunar_orientation.py).

Reported: the angle of the rotation between the two frames over 2000-2049 (sampled every 1.37 d), its largest
value, RMS and mean per axis (the mean: the IAU series' own bias, and the two ephemerides' principal-axes
definitions, DE421's against DE430's, which differ by a fraction of an arcsecond); the same without DE430's turn (the IAU mean-Earth axes alone)
as the scale; and what the departure moves the field by: the degree-100 acceleration at 100 and 1,000 km
altitude, turned by the worst epoch's rotation, against the field's own RMS.
"""

import argparse
import math
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
OUTPUT = REPO / "results" / "reference" / "lunar_orientation.md"
JD_J2000 = 2451545.0
ARCSEC = math.pi / (180.0 * 3600.0)


def _de421_librations():
    """(coefficients (intervals, 3, order), first TDB Julian date, days per interval) of DE421's librations."""
    import de421

    folder = Path(de421.__file__).parent
    constants = {name.decode(): value for name, value in np.load(folder / "constants.npy", allow_pickle=True)}
    coefficients = np.load(folder / "jpl-librations.npy")
    days = (constants["jomega"] - constants["jalpha"]) / coefficients.shape[0]
    return coefficients, float(constants["jalpha"]), float(days)


def _axes_rotation(axis: int, angle_rad: float) -> np.ndarray:
    """The passive rotation about `axis` (its own writing, not the module's under test)."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out = np.eye(3)
    out[i, i], out[i, j], out[j, i], out[j, j] = c, s, -s, c
    return out


def de421_pa_from_icrf(t_tdb_s: np.ndarray) -> np.ndarray:
    """(k, 3, 3): r_PA = R r_ICRF of DE421's librations at TDB seconds past J2000."""
    from numpy.polynomial import chebyshev

    coefficients, first_jd, days = _de421_librations()
    out = np.empty((len(t_tdb_s), 3, 3))
    for n, t in enumerate(np.asarray(t_tdb_s, dtype=float)):
        offset = JD_J2000 + t / 86400.0 - first_jd
        interval = int(offset // days)
        x = 2.0 * (offset - interval * days) / days - 1.0
        phi, theta, psi = (chebyshev.chebval(x, coefficients[interval, k]) for k in range(3))
        out[n] = _axes_rotation(2, psi) @ _axes_rotation(0, theta) @ _axes_rotation(2, phi)
    return out


def rotation_vector_arcsec(turn: np.ndarray) -> np.ndarray:
    """(3,) the small rotation `turn` (3, 3) makes, axis times angle, arcseconds (exact angle, its axis)."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(turn) - 1.0) / 2.0)))
    axis = np.array([turn[1, 2] - turn[2, 1], turn[2, 0] - turn[0, 2], turn[0, 1] - turn[1, 0]])
    norm = np.linalg.norm(axis)
    return np.zeros(3) if norm == 0.0 else axis / norm * angle / ARCSEC


def departures(t_tdb_s: np.ndarray, with_pa_turn: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(rotation vectors (k, 3) in arcseconds, the rotations (k, 3, 3)) taking DE421's principal axes to liaison's
    at each TDB time; without the turn, to the IAU mean-Earth axes (the scale the turn corrects)."""
    from liaison_cli.dynamics.lunar_orientation import PA_FROM_ME, moon_pa_from_icrf

    reference = de421_pa_from_icrf(t_tdb_s)
    turns = np.empty_like(reference)
    for n, t in enumerate(t_tdb_s):
        ours = moon_pa_from_icrf(float(t))
        turns[n] = (ours if with_pa_turn else PA_FROM_ME.T @ ours) @ reference[n].T
    return np.array([rotation_vector_arcsec(turn) for turn in turns]), turns


def _sample_times(first_year: int = 2000, last_year: int = 2049, step_days: float = 1.37) -> np.ndarray:
    start = (first_year - 2000) * 365.25 * 86400.0
    end = (last_year + 1 - 2000) * 365.25 * 86400.0
    return np.arange(start, end, step_days * 86400.0)


def _field_lines(worst_turn: np.ndarray, degree: int = 100, points_count: int = 2000) -> list[str]:
    from benchmarks.lunar_field import MOON_RADIUS_KM, accelerations, rms, sphere, turned
    from liaison_cli.dynamics.lunar_gravity import lunar_field

    field = lunar_field(degree)
    lines = ["| altitude km | field RMS m/s² | change by the worst epoch's departure, m/s² (share of the RMS) |",
             "|---|---|---|"]
    for altitude in (100.0, 1000.0):
        points = sphere(points_count, MOON_RADIUS_KM + altitude)
        base = accelerations(field, degree, points)
        moved = turned(field, degree, points, worst_turn)
        lines.append(f"| {altitude:.0f} | {rms(base):.3g} | {rms(moved - base):.3g} "
                     f"({100 * rms(moved - base) / rms(base):.2f} %) |")
    return lines


def main(argv=None) -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    times = _sample_times()
    vectors, turns = departures(times)
    angles = np.linalg.norm(vectors, axis=1)
    without = np.linalg.norm(departures(times, with_pa_turn=False)[0], axis=1)
    worst = int(np.argmax(angles))
    worst_year = 2000 + times[worst] / (365.25 * 86400.0)
    mean = vectors.mean(axis=0)
    parts = [
        "Written by `python -m benchmarks.lunar_orientation`; do not edit by hand. The rotation liaison turns "
        "GRGM1200A with (the IAU series for the mean-Earth axes, then DE430's turn to the principal axes) against "
        f"the principal axes of DE421's integrated librations (the `de421` package), {len(times)} epochs every "
        "1.37 d over 2000-2049 (TDB).", "",
        "| frame | largest angle, ″ | RMS angle, ″ | mean rotation (x, y, z), ″ |", "|---|---|---|---|",
        f"| liaison's principal axes | {angles.max():.1f} (in {worst_year:.1f}) | "
        f"{math.sqrt(np.mean(angles ** 2)):.1f} | ({mean[0]:+.1f}, {mean[1]:+.1f}, {mean[2]:+.1f}) |",
        f"| the IAU mean-Earth axes, without DE430's turn | {without.max():.1f} | "
        f"{math.sqrt(np.mean(without ** 2)):.1f} | |", "",
        f"At 1,738 km, {angles.max():.1f}″ is {angles.max() * ARCSEC * 1738e3:.0f} m along the surface. What the "
        "worst epoch's departure moves the degree-100 field by (2,000 points on each sphere):", "",
        *_field_lines(turns[worst])]
    OUTPUT.write_text("\n".join(parts) + "\n")
    print(OUTPUT.read_text())


if __name__ == "__main__":
    main()
