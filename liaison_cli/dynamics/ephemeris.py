"""JPL DE421, offline, evaluated by our own compiled Chebyshev code (003: the dated sky).

The file is `de421.bsp` as shipped by the `skyfield-data` package (no download at run time); `jplephem`
parses its DAF/SPK structure and hands over each segment's Chebyshev records. For a run we cut the records
covering its dates into one padded array, so the compiled dynamics evaluate positions and velocities with
no Python in the loop. Frame: ICRF axes; centre: the Earth (geocentric states, km and km/s). Time: TDB
seconds past J2000 (2000-01-01 12:00 TDB); `dynamics.timescales` converts calendar UTC to it.

Geocentric states: a system barycentre or the Sun is [SSB -> body] - [SSB -> EMB] - [EMB -> Earth]; the Moon
is [EMB -> Moon] - [EMB -> Earth]. Checked against skyfield on the same file (tests/unit/dynamics/test_ephemeris.py).
"""

import os
from dataclasses import dataclass

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import DE421_GM_KM3_S2, J2000_JD, SECONDS_PER_DAY


# Our body codes: NAIF barycentre ids 1-9 (planet systems), 10 the Sun, 301 the Moon.
BODY_MOON = 301
BODY_SUN = 10
BODY_EARTH = 399
SEGMENTS = ((0, 1), (0, 2), (0, 3), (0, 4), (0, 5), (0, 6), (0, 7), (0, 8), (0, 9), (0, 10), (3, 301), (3, 399))
SEG_EMB = 2  # (0, 3)
SEG_MOON = 10  # (3, 301)
SEG_EARTH = 11  # (3, 399)

GM_KM3_S2 = DE421_GM_KM3_S2  # the GM of each body code (dynamics.constants)


def de421_path() -> str:
    import skyfield_data

    return os.path.join(os.path.dirname(skyfield_data.__file__), "data", "de421.bsp")


@dataclass(frozen=True, eq=False)
class EphemerisWindow:
    """Chebyshev records of the SEGMENTS covering [start, end] (TDB s past J2000), padded into one array.

    coeffs (S, 3, R, N): per segment, component, record, coefficient (zero padding); start_s (S,) the first
    kept record's start; interval_s (S,) record length; n_records (S,)."""

    coeffs: np.ndarray
    start_s: np.ndarray
    interval_s: np.ndarray
    n_records: np.ndarray
    first_s: float
    last_s: float


_SPK = None


def _kernel():
    global _SPK
    if _SPK is None:
        from jplephem.spk import SPK

        _SPK = SPK.open(de421_path())
    return _SPK


def de421_span_s() -> tuple[float, float]:
    """The dates DE421 covers, as TDB seconds past J2000."""
    segment = _kernel()[0, 10]
    return ((segment.start_jd - J2000_JD) * SECONDS_PER_DAY, (segment.end_jd - J2000_JD) * SECONDS_PER_DAY)


def load_window(start_s: float, end_s: float, margin_s: float = 2 * SECONDS_PER_DAY) -> EphemerisWindow:
    """The records of every segment needed between start_s and end_s (plus a margin)."""
    lo_span, hi_span = de421_span_s()
    lo, hi = max(start_s - margin_s, lo_span), min(end_s + margin_s, hi_span)
    if start_s < lo_span or end_s > hi_span:
        raise ValueError(f"DE421 covers {lo_span / SECONDS_PER_DAY / 365.25 + 2000:.1f} to "
                         f"{hi_span / SECONDS_PER_DAY / 365.25 + 2000:.1f} only")
    kernel = _kernel()
    parts = []
    for center, target in SEGMENTS:
        init_jd, interval_days, coefficients = kernel[center, target].load_array()
        first = int(np.floor((lo / SECONDS_PER_DAY + J2000_JD - init_jd) / interval_days))
        last = int(np.floor((hi / SECONDS_PER_DAY + J2000_JD - init_jd) / interval_days))
        first, last = max(first, 0), min(last, coefficients.shape[1] - 1)
        parts.append(((init_jd + first * interval_days - J2000_JD) * SECONDS_PER_DAY, interval_days * SECONDS_PER_DAY,
                      coefficients[:, first : last + 1, :]))
    n_rec = max(p[2].shape[1] for p in parts)
    n_coef = max(p[2].shape[2] for p in parts)
    coeffs = np.zeros((len(parts), 3, n_rec, n_coef))
    for s, (_, _, block) in enumerate(parts):
        coeffs[s, :, : block.shape[1], : block.shape[2]] = block
    return EphemerisWindow(coeffs, np.array([p[0] for p in parts]), np.array([p[1] for p in parts]),
                           np.array([p[2].shape[1] for p in parts], dtype=np.int64), lo, hi)


@njit(cache=True, inline="always")
def _record_at(start_s, interval_s, n_records, seg, t_s):
    """(index, s): segment `seg`'s record holding t_s (the first or last one outside them) and t_s's place in it,
    s in [-1, 1]."""
    offset = t_s - start_s[seg]
    index = int(np.floor(offset / interval_s[seg]))
    if index < 0:
        index = 0
    if index > n_records[seg] - 1:
        index = n_records[seg] - 1
    return index, 2.0 * (offset - index * interval_s[seg]) / interval_s[seg] - 1.0


@njit(cache=True)
def segment_state(coeffs, start_s, interval_s, n_records, seg, t_s, out):
    """Position (km) and velocity (km/s) of segment `seg` at t_s into out (6,): Chebyshev series and its
    derivative, T_k and dT_k/ds by their recurrences, s in [-1, 1] across the record."""
    index, s = _record_at(start_s, interval_s, n_records, seg, t_s)
    n_coef = coeffs.shape[3]
    for axis in range(3):
        t_prev, t_now = 1.0, s  # T_0, T_1
        d_prev, d_now = 0.0, 1.0  # T_0', T_1'
        c = coeffs[seg, axis, index]
        position = c[0] + c[1] * s if n_coef > 1 else c[0]
        velocity = c[1] if n_coef > 1 else 0.0
        for k in range(2, n_coef):
            t_next = 2.0 * s * t_now - t_prev
            d_next = 2.0 * t_now + 2.0 * s * d_now - d_prev
            position += c[k] * t_next
            velocity += c[k] * d_next
            t_prev, t_now = t_now, t_next
            d_prev, d_now = d_now, d_next
        out[axis] = position
        out[3 + axis] = velocity * 2.0 / interval_s[seg]


@njit(cache=True)  # a call, not inlined: three call sites would compile three copies (geocentric_positions_into
# compiled with its callee in 2.5 s inlined, 1.4 s as a call; the derivative took the same time within noise)
def _segment_position_into(coeffs, start_s, interval_s, n_records, seg, t_s, out):
    """segment_state's position alone (km) into out (3,), by the same arithmetic (the same numbers to the last bit):
    the Chebyshev series without its derivative's recurrence."""
    index, s = _record_at(start_s, interval_s, n_records, seg, t_s)
    n_coef = coeffs.shape[3]
    for axis in range(3):
        t_prev, t_now = 1.0, s  # T_0, T_1
        c = coeffs[seg, axis, index]
        position = c[0] + c[1] * s if n_coef > 1 else c[0]
        for k in range(2, n_coef):
            t_next = 2.0 * s * t_now - t_prev
            position += c[k] * t_next
            t_prev, t_now = t_now, t_next
        out[axis] = position


@njit(cache=True)
def geocentric_positions_into(coeffs, start_s, interval_s, n_records, bodies, t_s, out, work):
    """Geocentric ICRF positions (km) of the body codes `bodies` (B,) at TDB t_s into out (B, 3): geocentric_state's
    positions bit for bit (the same differences in the same order), with the Earth's and the EMB's segments evaluated
    once for every body and no velocities. work (3, 3): scratch. The dynamics' right-hand side calls this at every
    stage (10 bodies: 12 position series instead of 29 series with their derivatives, and no allocation)."""
    earth, emb, segment = work[0], work[1], work[2]
    _segment_position_into(coeffs, start_s, interval_s, n_records, np.int64(SEG_EARTH), t_s, earth)
    with_emb = False
    for b in range(bodies.shape[0]):
        if bodies[b] == BODY_MOON:
            _segment_position_into(coeffs, start_s, interval_s, n_records, np.int64(SEG_MOON), t_s, segment)
            for i in range(3):
                out[b, i] = segment[i] - earth[i]
            continue
        if not with_emb:
            _segment_position_into(coeffs, start_s, interval_s, n_records, np.int64(SEG_EMB), t_s, emb)
            with_emb = True
        _segment_position_into(coeffs, start_s, interval_s, n_records, bodies[b] - 1, t_s, segment)
        for i in range(3):
            out[b, i] = segment[i] - earth[i]
            out[b, i] -= emb[i]


@njit(cache=True)
def geocentric_state(coeffs, start_s, interval_s, n_records, body, t_s):
    """Geocentric ICRF state (6,) of a body code (1-10 barycentres and Sun, 301 the Moon) at TDB t_s."""
    a = np.empty(6)
    b = np.empty(6)
    out = np.empty(6)
    segment_state(coeffs, start_s, interval_s, n_records, np.int64(SEG_EARTH), t_s, b)  # np.int64: no literal
    if body == BODY_MOON:
        segment_state(coeffs, start_s, interval_s, n_records, np.int64(SEG_MOON), t_s, a)
        for i in range(6):
            out[i] = a[i] - b[i]
        return out
    segment_state(coeffs, start_s, interval_s, n_records, body - 1, t_s, a)  # (0, body) sits at index body - 1
    for i in range(6):
        out[i] = a[i] - b[i]
    segment_state(coeffs, start_s, interval_s, n_records, np.int64(SEG_EMB), t_s, a)
    for i in range(6):
        out[i] -= a[i]
    return out
