"""Observability of a scenario from its truth, without any a-priori covariance (001 §5.1, 000 Eq. 25-28).

For each epoch t_k and link, the partials H~_k of the observable are mapped to the epoch t0 with the STM,
H_k = H~_k Phi(t_k, t0) (Eq. 25). Then:
- information matrix  Lambda = sum_k H_k^T W H_k, W = 1 / sigma^2 (Eq. 27), its SVD (Eq. 28), condition
  number sigma_max / sigma_min and local unobservability index 1 / sigma_min;
- observability Gramian  sum_k H_k^T H_k (001 Eq. 29), the same without the weights;
- observation effectiveness: sqrt(max eig) of each spacecraft's 3x3 position / velocity block of the
  single-epoch information Lambda_k = H_k^T W H_k (001 Eq. 56-57).
State order: 6 per spacecraft (x, y, z, vx, vy, vz) in LU and LU/TU, as in the filter.
"""

from dataclasses import dataclass

import numpy as np

from liaison_cli.dynamics.constants import MU, TU_S
from liaison_cli.dynamics.crtbp import jacobian
from liaison_cli.dynamics.integrators.dop853 import dop853_state_stm
from liaison_cli.dynamics.integrators.rk4 import rk4_variational
from liaison_cli.measurements.registry import OBSERVABLES as REGISTERED
from liaison_cli.measurements.registry import get_observable, predict_along

AXES = ("x", "y", "z", "vx", "vy", "vz")
# Scalar observables that depend on the two spacecraft states alone (no clock): range and range-rate.
OBSERVABLES = tuple(name for name, obs in REGISTERED.items() if len(obs.channels) == 1 and not obs.needs_receiver_clock)


@dataclass(frozen=True, eq=False)
class ObservabilityResult:
    """information (n, n); gramian (n, n); singular_values (n,) descending; right_vectors (n, n) with
    column j = state direction of singular value j; effectiveness_position / _velocity (m, n_sc)."""

    labels: tuple
    information: np.ndarray
    gramian: np.ndarray
    singular_values: np.ndarray
    right_vectors: np.ndarray
    effectiveness_position: np.ndarray
    effectiveness_velocity: np.ndarray

    @property
    def condition_number(self) -> float:
        return float(self.singular_values[0] / self.singular_values[-1])

    @property
    def unobservability_index(self) -> float:
        return float(1.0 / self.singular_values[-1])

    @property
    def gramian_condition_number(self) -> float:
        s = np.linalg.svd(self.gramian, compute_uv=False)
        return float(s[0] / s[-1])

    def direction(self, which: int, top: int = 3) -> list[tuple[str, float]]:
        """The `top` largest components (label, weight) of singular direction `which` (0 = most observable)."""
        v = self.right_vectors[:, which]
        order = np.argsort(-np.abs(v))[:top]
        return [(self.labels[i], float(v[i])) for i in order]


def stm_from_t0(states0, times_tu, mu=MU):
    """Truth states (m, n_sc, 6) and per-spacecraft Phi(t_k, t0) (m, n_sc, 6, 6)."""
    pairs = [dop853_state_stm(s0, times_tu, mu) for s0 in states0]
    return np.stack([p[0] for p in pairs], axis=1), np.stack([p[1] for p in pairs], axis=1)


def _partials(receiver_states, transponder_states, observable):
    """d(observable)/d(state) of the receiver and of the transponder at every epoch: (m, 6) each."""
    kind = get_observable(observable).channels[0].code
    _, g_receiver, g_transponder = predict_along(kind, np.ascontiguousarray(receiver_states),
                                                 np.ascontiguousarray(transponder_states), 0)
    return g_receiver, g_transponder


def _link_partials(states, receiver, transponder, observable):
    """As _partials, for two spacecraft of states (m, n_sc, 6)."""
    return _partials(states[:, receiver], states[:, transponder], observable)


def analyse(states0, times_tu, links, sigma, observable: str = "range", names=None, mu=MU,
            skip_first: bool = True, propagated=None, known_states=None, visible=None) -> ObservabilityResult:
    """states0 (n_sc, 6) at t0; times_tu (m,); links: (receiver, transponder) index pairs; sigma (LU or
    LU/TU) of the observable. `propagated`: optional (states (m, n_sc, 6), phis (m, n_sc, 6, 6)) to reuse.
    Known participants (ground stations, known spacecraft): an index n_sc + j is known_states[:, j] (m, k, 6),
    a given trajectory with no state of its own to estimate. visible: optional (n_links, m) bool, epochs a
    link measures (elevation masks, occultation); other epochs add no information."""
    if observable not in OBSERVABLES:
        raise ValueError(f"observable {observable!r}; allowed: {', '.join(OBSERVABLES)}")
    states0 = np.asarray(states0, dtype=float)
    n_sc = states0.shape[0]
    n = 6 * n_sc
    names = names or [f"sc{i}" for i in range(n_sc)]
    states, phis = propagated if propagated is not None else stm_from_t0(states0, times_tu, mu)
    first = 1 if skip_first else 0
    states, phis = states[first:], phis[first:]
    m = states.shape[0]
    weight = 1.0 / sigma**2
    information = np.zeros((n, n))
    gramian = np.zeros((n, n))
    block_pos = np.zeros((m, n_sc, 3, 3))
    block_vel = np.zeros((m, n_sc, 3, 3))
    known = None if known_states is None else np.asarray(known_states)[first:]
    for index, (receiver, transponder) in enumerate(links):
        ends = [states[:, e] if e < n_sc else known[:, e - n_sc] for e in (receiver, transponder)]
        H = np.zeros((m, n))  # rows H_k = H~_k Phi(t_k, t0), spacecraft block by block (Eq. 25)
        for end, g in zip((receiver, transponder), _partials(*ends, observable)):
            if end < n_sc:  # a known end has no state to map
                H[:, 6 * end : 6 * end + 6] = np.einsum("mi,mij->mj", g, phis[:, end])
        if visible is not None:
            H[~np.asarray(visible[index], dtype=bool)[first:]] = 0.0
        gramian += H.T @ H
        information += weight * (H.T @ H)
        for s in range(n_sc):
            hp = H[:, 6 * s : 6 * s + 3]
            hv = H[:, 6 * s + 3 : 6 * s + 6]
            block_pos[:, s] += weight * np.einsum("mi,mj->mij", hp, hp)
            block_vel[:, s] += weight * np.einsum("mi,mj->mij", hv, hv)
    pad = np.full((first, n_sc), np.nan)
    eff_pos = np.vstack([pad, np.sqrt(np.clip(np.linalg.eigvalsh(block_pos)[..., -1], 0.0, None))])
    eff_vel = np.vstack([pad, np.sqrt(np.clip(np.linalg.eigvalsh(block_vel)[..., -1], 0.0, None))])
    _, singular, vt = np.linalg.svd(information)
    labels = tuple(f"{name}.{axis}" for name in names for axis in AXES)
    return ObservabilityResult(labels, information, gramian, singular, vt.T, eff_pos, eff_vel)


def taylor_stm(state_end, dt_tu, mu=MU, order: int = 2):
    """Series approximation of Phi(t + dt, t) = I + A dt + (A dt)^2 / 2 + ... with A evaluated at the end
    of the interval (001 Eq. 46-51). (6,) -> (6, 6)."""
    A = jacobian(state_end, mu) * dt_tu
    phi = np.eye(6)
    term = np.eye(6)
    for j in range(1, order + 1):
        term = term @ A / j
        phi = phi + term
    return phi


def taylor_stm_errors(state0, duration_tu, steps_s, mu=MU, order: int = 2):
    """Relative error ||Phi_taylor - Phi_num||_F / ||Phi_num||_F of the one-step STM over every step of
    length `step_s` along the orbit; returns {step_s: (rms, std)} (001 Appendix B). The numerical STM of
    each step is RK4 with 16 substeps on state and STM alike (its own error is below 1e-10 at these step sizes)."""
    out = {}
    for step_s in steps_s:
        dt = step_s / TU_S
        times = np.arange(0.0, duration_tu + 1e-12, dt)
        states = dop853_state_stm(state0, times, mu)[0]
        errors = []
        for k in range(len(times) - 1):
            numeric = rk4_variational(states[k], dt, 16, np.array([mu]))[1]
            approx = taylor_stm(states[k + 1], dt, mu, order)
            errors.append(np.linalg.norm(approx - numeric) / np.linalg.norm(numeric))
        errors = np.array(errors)
        out[step_s] = (float(np.sqrt(np.mean(errors**2))), float(np.std(errors)))
    return out
