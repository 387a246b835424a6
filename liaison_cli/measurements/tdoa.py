"""Time and frequency difference of arrival (004 §3): one transmitter's signal received at two receivers.

Ends: `receiver` (1), `transponder` (the transmitter, t) and `second_receiver` (2). Channel values, in
filter units, and what they are in SI:
- TDoA: rho_2 - rho_1 (LU), the path difference; (rho_2 - rho_1) / c seconds (scale LU / c) is how much
  later receiver 2 hears the signal than receiver 1.
- FDoA: rho_dot_1 - rho_dot_2 (LU/TU, SI m/s); the frequency difference is f_2 - f_1 = (f_c / c) times
  it, for the carrier f_c, and its sigma comes from the Hz value: sigma_m_s = sigma_Hz c / f_c.

Instantaneous form (`measurement.light_time: false` in the truth, `filter.range_model: geometric` in the
filter): every end at the epoch t, rho_i = |r_i - r_t| and rho_dot_i = u_i . (v_i - v_t), u_i = (r_i - r_t)
/ rho_i. Its partials are those of range and range-rate, with opposite signs at the two receivers.

Light-time form (flag FLAG_LIGHT_TIME: `measurement.light_time: true`, `filter.range_model: light_time`):
one wavefront, as a correlator of the two recordings measures it. The transmitter emits at t_e; the
wavefront reaches receiver 1 at t_1 and receiver 2 at t_2:
    c (t_1 - t_e) = |r_1(t_1) - r_t(t_e)|,    c (t_2 - t_e) = |r_2(t_2) - r_t(t_e)|.            (1)
Time tag: the channel's epoch t is receiver 1's arrival time, t_1 = t; so t_e = t - tau_1 and t_2 = t + Delta,
the TDoA is Delta = t_2 - t_1 and the value c Delta = rho_2 - rho_1 with rho_i = c (t_i - t_e). Receiver 2's
state at t is moved to t_2 (it is not read at a common reception time, the form used before issue 26: that
one differs by ~ rho_dot_2 (rho_2 - rho_1) / c^2, 0.4 us median and 0.92 us at most for 004's GEO pair).
FDoA: the received frequencies of that same wavefront, f_i = f_c dt_e / dt_i (wavefronts emitted dt_e apart
arrive dt_i apart at receiver i, each at its own arrival time). Differentiating (1):
    rho_dot_i = c (1 - f_i / f_c) = u_i . (v_i(t_i) - v_t(t_e)) / (1 - u_i . v_t(t_e) / c),          (2)
    u_i = (r_i(t_i) - r_t(t_e)) / rho_i,
so f_2 - f_1 = (f_c / c) (rho_dot_1 - rho_dot_2) holds exactly for Newtonian light propagation. The model
is Newtonian in truth and filter alike: no v^2 / 2 c^2 or gravitational frequency shift (~1e-10 f_c; equal,
hence cancelling, for two GEO receivers at one speed and height), no Shapiro delay, no media.

Kinematics over the light time: an end moves from its state at t with constant acceleration, r(t + s) =
r + v s + a s^2 / 2 and v(t + s) = v + a s, s = -tau_1 (1.2-1.5 s) for the transmitter and Delta (|Delta| <
0.1 s for 004's pairs) for receiver 2; the neglected jerk moves a GEO receiver by < 1e-8 m. An end given
as 9 numbers carries its acceleration after its state (LU/TU^2, in the states' frame); an end of 6 moves
uniformly (no acceleration in the inertial frame). The truth gives every end its acceleration
(trajectories' `.accelerations`); the filter gives the known participants theirs (their rows of
known_states) and moves estimated ends uniformly: for 004's EML2 transmitter (< 4e-3 m/s^2) that leaves
< 7e-5 m/s in the FDoA and < 1e-4 m in the TDoA path (1e-3 of their sigmas). Receiver 2's acceleration is
not negligible: a GEO receiver's 0.224 m/s^2 over |Delta| < 0.096 s moves the FDoA by up to 1.5 cm/s
(2.7 sigma), hence the known receivers' accelerations in the filter.
Frame: (1)-(2) hold in an inertial frame. With FLAG_ROTATING_FRAME (the CRTBP frame, turning at 1 rad/TU
about z) every end is first written in the inertial frame aligned with it at t: v + z x r and
a + 2 z x v + z x (z x r) (straight lines in the rotating frame are not light rays: read as inertial, the
CRTBP geometry of tests/unit/measurements/test_tdoa.py is off by 55 ns, 17 m of path).
Solution: tau_1, then Delta, by fixed-point iteration of (1) (contraction |v| / c ~ 1e-5: four passes
reach rounding). Partials: exact, the tangent of the same equations (implicit differentiation of (1) and
(2)) taken one input direction at a time: scalar arithmetic on 3-tuples, no arrays.
"""

import numpy as np
from numba import njit

from liaison_cli.dynamics.constants import LU_KM, M_S_PER_VU, SPEED_OF_LIGHT_KM_S, SPEED_OF_LIGHT_LU_TU
from liaison_cli.dynamics.trajectory import states_with_accelerations
from liaison_cli.measurements.observable import FLAG_ROTATING_FRAME, ChannelKind, Observable
from liaison_cli.measurements.range import FLAG_LIGHT_TIME, geometric_range, geometric_range_gradient, light_time_flags
from liaison_cli.measurements.range_rate import range_rate, range_rate_gradient

KIND_TDOA = 9
KIND_FDOA = 10
SECONDS_PER_LU = LU_KM / SPEED_OF_LIGHT_KM_S  # light time across one LU of path difference
FIXED_POINT_PASSES = 4  # of (1), each shrinking the error by |v| / c < 1e-4
ZERO3 = (0.0, 0.0, 0.0)


# 3-vectors as tuples: values in registers, nothing allocated per call.
@njit(cache=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True)
def _lin(p, a, q, b):
    """p a + q b."""
    return (p * a[0] + q * b[0], p * a[1] + q * b[1], p * a[2] + q * b[2])


@njit(cache=True)
def _z_cross(a):
    """z x a: the velocity a point at a has in a frame turning at 1 rad/TU about z."""
    return (-a[1], a[0], 0.0)


@njit(cache=True)
def _norm(a):
    return np.sqrt(_dot(a, a))


@njit(cache=True)
def _inertial(x, rotating):
    """An end's position, velocity and acceleration at t in the inertial frame aligned with the states'
    frame at t (module docstring: Frame); (r, v, a) 3-tuples. No acceleration given: a = 0."""
    r, v = (x[0], x[1], x[2]), (x[3], x[4], x[5])
    has_acceleration = x.shape[0] >= 9
    a = (x[6], x[7], x[8]) if has_acceleration else ZERO3
    if rotating:
        if has_acceleration:
            a = _lin(1.0, _lin(1.0, a, 2.0, _z_cross(v)), 1.0, _z_cross(_z_cross(r)))
        v = _lin(1.0, v, 1.0, _z_cross(r))
    return r, v, a


@njit(cache=True)
def _moved(r, v, a, s):
    """Position s TU after t under constant acceleration."""
    return (r[0] + s * (v[0] + 0.5 * s * a[0]), r[1] + s * (v[1] + 0.5 * s * a[1]), r[2] + s * (v[2] + 0.5 * s * a[2]))


@njit(cache=True)
def _solve_wavefront(r1, rt, vt, at, r2, v2, a2):
    """(1) for one wavefront reaching receiver 1 at t: (tau_1, Delta) in TU, by fixed-point iteration."""
    c = SPEED_OF_LIGHT_LU_TU
    tau = _norm(_lin(1.0, r1, -1.0, rt)) / c
    for _ in range(FIXED_POINT_PASSES):
        tau = _norm(_lin(1.0, r1, -1.0, _moved(rt, vt, at, -tau))) / c
    emitted = _moved(rt, vt, at, -tau)
    delta = _norm(_lin(1.0, r2, -1.0, emitted)) / c - tau
    for _ in range(FIXED_POINT_PASSES):
        delta = _norm(_lin(1.0, _moved(r2, v2, a2, delta), -1.0, emitted)) / c - tau
    return tau, delta


@njit(cache=True)
def _paths(r1, v1, rt, vt, at, r2, v2, a2, tau, delta):
    """The wavefront's two paths at the solution of (1): ((u_1, u_2, v_t(t_e), v_2(t_2)),
    (rho_1, rho_2, d_1, d_2, rho_dot_1, rho_dot_2)) with d_i = 1 - u_i . v_t(t_e) / c, the denominators of (2)."""
    c = SPEED_OF_LIGHT_LU_TU
    emitted = _moved(rt, vt, at, -tau)
    w1 = _lin(1.0, r1, -1.0, emitted)
    w2 = _lin(1.0, _moved(r2, v2, a2, delta), -1.0, emitted)
    rho1, rho2 = _norm(w1), _norm(w2)
    u1, u2 = _lin(1.0 / rho1, w1, 0.0, ZERO3), _lin(1.0 / rho2, w2, 0.0, ZERO3)
    vt_e = _lin(1.0, vt, -tau, at)
    v2_a = _lin(1.0, v2, delta, a2)
    d1, d2 = 1.0 - _dot(u1, vt_e) / c, 1.0 - _dot(u2, vt_e) / c
    rate1 = _dot(u1, _lin(1.0, v1, -1.0, vt_e)) / d1
    rate2 = _dot(u2, _lin(1.0, v2_a, -1.0, vt_e)) / d2
    return (u1, u2, vt_e, v2_a), (rho1, rho2, d1, d2, rate1, rate2)


@njit(cache=True)
def _rate_tangent(u, du, v, dv, vt, dvt, d, rate):
    """The change of (2), rho_dot = u . (v - v_t) / d with d = 1 - u . v_t / c, for changes du, dv, dvt."""
    s, ds = _lin(1.0, v, -1.0, vt), _lin(1.0, dv, -1.0, dvt)
    return (_dot(du, s) + _dot(u, ds)) / d + rate * (_dot(du, vt) + _dot(u, dvt)) / (SPEED_OF_LIGHT_LU_TU * d)


@njit(cache=True)
def _tangent(rate, d_first, d_transmitter, d_second, paths, accelerations, v1, tau, delta):
    """The change of the TDoA (or, with `rate`, the FDoA) value for changes of the ends' inertial
    kinematics d_first = (dr, dv), d_transmitter = d_second = (dr, dv, da), from (1) and (2) differentiated
    with tau_1 and Delta following: d rho_1 = u_1 . (dr_1 - dR_e) / d_1, with dR_e the emission point's change
    at fixed tau_1 (R_e moves by -v_t(t_e) dtau_1 as tau_1 grows), and likewise for rho_2 = c (tau_1 + Delta)."""
    c = SPEED_OF_LIGHT_LU_TU
    (u1, u2, vt_e, v2_a), (rho1, rho2, d1, d2, rate1, rate2) = paths
    at, a2 = accelerations
    dr1, dv1 = d_first
    drt, dvt, dat = d_transmitter
    dr2, dv2, da2 = d_second
    de_fixed = _lin(1.0, _lin(1.0, drt, -tau, dvt), 0.5 * tau * tau, dat)
    drho1 = _dot(u1, _lin(1.0, dr1, -1.0, de_fixed)) / d1
    dtau = drho1 / c
    de = _lin(1.0, de_fixed, -dtau, vt_e)  # the emission point's whole change
    dr2_fixed = _lin(1.0, _lin(1.0, dr2, delta, dv2), 0.5 * delta * delta, da2)
    drho2 = _dot(u2, _lin(1.0, _lin(1.0, dr2_fixed, -dtau, v2_a), -1.0, de)) / (1.0 - _dot(u2, v2_a) / c)
    if not rate:
        return drho2 - drho1
    ddelta = drho2 / c - dtau
    dw1 = _lin(1.0, dr1, -1.0, de)
    dw2 = _lin(1.0, _lin(1.0, dr2_fixed, ddelta, v2_a), -1.0, de)
    du1 = _lin(1.0 / rho1, dw1, -drho1 / rho1, u1)  # d(w / |w|) = (dw - u d|w|) / |w|
    du2 = _lin(1.0 / rho2, dw2, -drho2 / rho2, u2)
    dvt_e = _lin(1.0, _lin(1.0, dvt, -tau, dat), -dtau, at)
    dv2_a = _lin(1.0, _lin(1.0, dv2, delta, da2), ddelta, a2)
    return (_rate_tangent(u1, du1, v1, dv1, vt_e, dvt_e, d1, rate1)
            - _rate_tangent(u2, du2, v2_a, dv2_a, vt_e, dvt_e, d2, rate2))


@njit(cache=True)
def _seed(i, rotating, has_acceleration):
    """The inertial (dr, dv, da) of a unit change of element i of an end's state (module docstring: Frame;
    a given acceleration is a fixed input, but in a rotating frame its inertial value depends on r and v)."""
    unit = (1.0 if i % 3 == 0 else 0.0, 1.0 if i % 3 == 1 else 0.0, 1.0 if i % 3 == 2 else 0.0)
    dr = unit if i < 3 else ZERO3
    dv = ZERO3 if i < 3 else unit
    da = ZERO3
    if rotating:
        if has_acceleration:
            da = _lin(2.0, _z_cross(dv), 1.0, _z_cross(_z_cross(dr)))
        dv = _lin(1.0, dv, 1.0, _z_cross(dr))
    return dr, dv, da


@njit(cache=True)
def wavefront_difference(rate, x_first, x_transmitter, x_second, rotating, g_first, g_transmitter, g_second):
    """The light-time form (module docstring): TDoA path difference rho_2 - rho_1 or, with `rate`, FDoA
    rho_dot_1 - rho_dot_2 (filter units) of the wavefront reaching the first receiver at t; its partials with
    respect to the ends' states (6,) into g_first, g_transmitter, g_second. Ends: (6,) states or (9,) states
    and accelerations; `rotating`: the states' frame turns at 1 rad/TU about z."""
    r1, v1, _ = _inertial(x_first, rotating)
    rt, vt, at = _inertial(x_transmitter, rotating)
    r2, v2, a2 = _inertial(x_second, rotating)
    tau, delta = _solve_wavefront(r1, rt, vt, at, r2, v2, a2)
    paths = _paths(r1, v1, rt, vt, at, r2, v2, a2, tau, delta)
    still2, still3 = (ZERO3, ZERO3), (ZERO3, ZERO3, ZERO3)
    for i in range(6):
        dr, dv, _ = _seed(i, rotating, np.bool_(False))  # receiver 1 is not moved: its acceleration does not enter
        g_first[i] = _tangent(rate, (dr, dv), still3, still3, paths, (at, a2), v1, tau, delta)
        g_transmitter[i] = _tangent(rate, still2, _seed(i, rotating, x_transmitter.shape[0] >= 9), still3, paths,
                                    (at, a2), v1, tau, delta)
        g_second[i] = _tangent(rate, still2, still3, _seed(i, rotating, x_second.shape[0] >= 9), paths, (at, a2), v1,
                               tau, delta)
    rho1, rho2, _, _, rate1, rate2 = paths[1]
    return rate1 - rate2 if rate else rho2 - rho1


@njit(cache=True)  # a call, not inlined: keeps the EKF loop small for scenarios without TDoA (compile time)
def predict_difference(kind, x_first, x_transmitter, x_second, flags, g_first, g_transmitter, g_second):
    """TDoA path difference rho_2 - rho_1 or FDoA rate difference rho_dot_1 - rho_dot_2 (filter units),
    with the partials with respect to the three ends' states (6,) each; FLAG_LIGHT_TIME: one wavefront
    (wavefront_difference), else the instantaneous form."""
    if flags & FLAG_LIGHT_TIME:
        return wavefront_difference(kind == KIND_FDOA, x_first, x_transmitter, x_second,
                                    (flags & FLAG_ROTATING_FRAME) != 0, g_first, g_transmitter, g_second)
    if kind == KIND_TDOA:
        g1 = geometric_range_gradient(x_first[0:3], x_transmitter[0:3])
        g2 = geometric_range_gradient(x_second[0:3], x_transmitter[0:3])
        for i in range(3):
            g_first[i] = -g1[i]
            g_second[i] = g2[i]
            g_transmitter[i] = g1[i] - g2[i]
            g_first[3 + i] = 0.0
            g_second[3 + i] = 0.0
            g_transmitter[3 + i] = 0.0
        return geometric_range(x_second[0:3], x_transmitter[0:3]) - geometric_range(x_first[0:3], x_transmitter[0:3])
    g1 = range_rate_gradient(x_first, x_transmitter)
    g2 = range_rate_gradient(x_second, x_transmitter)
    for i in range(6):
        g_first[i] = g1[i]
        g_second[i] = -g2[i]
        g_transmitter[i] = g2[i] - g1[i]
    return range_rate(x_first, x_transmitter) - range_rate(x_second, x_transmitter)


@njit(cache=True)
def difference_along(kind, first, transmitter, second, flags):
    """predict_difference at every epoch of (m, 6) or (m, 9) end tables: the values (m,)."""
    out = np.empty(first.shape[0])
    g_first, g_transmitter, g_second = np.empty(6), np.empty(6), np.empty(6)
    for k in range(first.shape[0]):
        out[k] = predict_difference(kind, first[k], transmitter[k], second[k], flags, g_first, g_transmitter,
                                    g_second)
    return out


def _simulate(code, receiver, transmitter, light_time: bool, second=None):
    """The truth (m,): one wavefront, every end moved with its own acceleration (module docstring), or
    without light time the instantaneous form."""
    ends = (receiver, transmitter, second)
    if not light_time:
        return difference_along(code, *(end.states for end in ends), 0)
    frames = {bool(end.rotating_frame) for end in ends}
    if len(frames) != 1:
        raise ValueError("tdoa / fdoa: the three ends' trajectories are in different frames")
    flags = FLAG_LIGHT_TIME | (FLAG_ROTATING_FRAME if frames.pop() else 0)
    return difference_along(code, *(states_with_accelerations(end) for end in ends), flags)


def _sigma_tdoa(noise, receiver):
    return (noise.tdoa_sigma_ns * 1e-9 / SECONDS_PER_LU,)


def _sigma_fdoa(noise, receiver):
    sigma_m_s = noise.fdoa_sigma_hz * SPEED_OF_LIGHT_KM_S * 1e3 / noise.carrier_frequency_hz
    return (sigma_m_s / M_S_PER_VU,)


def _missing_tdoa(noise):
    return None if noise.tdoa_sigma_ns is not None else "the noise section has no 'tdoa_sigma_ns' (004: 20 ns)"


def _missing_fdoa(noise):
    missing = [key for key in ("fdoa_sigma_hz", "carrier_frequency_hz") if getattr(noise, key) is None]
    if not missing:
        return None
    return f"the noise section has no {' / '.join(repr(k) for k in missing)} (004: 0.04 Hz; the carrier is yours)"


TDOA = Observable(
    name="tdoa",
    channels=(ChannelKind(KIND_TDOA, "tdoa", "s", SECONDS_PER_LU),),
    sigma=_sigma_tdoa,
    simulate=_simulate,
    needs_second_receiver=True,
    light_time_from_states=True,
    end_accelerations=True,
    filter_flags=light_time_flags,
    missing_noise=_missing_tdoa,
    description="time difference of arrival at the second receiver minus the first (s)",
)

FDOA = Observable(
    name="fdoa",
    channels=(ChannelKind(KIND_FDOA, "fdoa", "m/s", M_S_PER_VU),),
    sigma=_sigma_fdoa,
    simulate=_simulate,
    needs_second_receiver=True,
    light_time_from_states=True,
    end_accelerations=True,
    filter_flags=light_time_flags,
    missing_noise=_missing_fdoa,
    description="frequency difference of arrival as the range-rate difference (m/s); Hz = value f_c / c",
)
