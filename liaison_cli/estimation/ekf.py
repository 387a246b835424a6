"""Extended Kalman filter steps (Turan et al. 2022, Eq. 12, 21-24), numba-compiled, textbook names.

n = state size (6 per spacecraft, then clock and constant blocks). Measurements are processed one scalar at a time with a diagonal
R, which is algebraically the batch update (Eq. 21-23) and needs no matrix inverse.
"""

import numpy as np
from numba import njit

from liaison_cli.estimation.blocks import BLOCK_CONSTANT, BLOCK_EMPIRICAL, BLOCK_PARAMETER, BLOCK_SPACECRAFT


@njit(cache=True)
def predict_covariance_blocks(P, Phi, Q, out, block_kind, block_start, block_size):
    """P_bar = Phi P Phi^T + Q (Eq. 12) for a block-diagonal Phi, written into `out` (and returned); see
    predict_covariance_into."""
    return predict_covariance_into(P, Phi, Q, out, np.empty((6, 6)), block_kind, block_start, block_size)


@njit(cache=True)
def predict_covariance_into(P, Phi, Q, out, tmp, block_kind, block_start, block_size):
    """P_bar = Phi P Phi^T + Q (Eq. 12) for a block-diagonal Phi, written into `out` (and returned); tmp (6, 6)
    scratch.

    P, Phi, Q, out: (n, n); block_kind / block_start / block_size (B,): the state layout (see
    estimation.blocks). Phi's diagonal blocks are read, and the coupling columns of parameter blocks;
    constant and parameter blocks have identity transition and skip their products. Each pair of blocks is
    done on its own, P_bar[a, b] = Phi_a P[a, b] Phi_b^T + Q[a, b]: no dense n x n product and no temporaries
    beyond one block. Symmetric by construction (upper triangle mirrored).

    A dynamics parameter p couples its spacecraft s: Phi = Phi_bd + G with G = gamma at (rows s, column p).
    Since row p of Phi_bd is the identity's, Phi = (I + G) Phi_bd, and with no process noise on p
    (Q[p, :] = 0, filter_arrays), Phi P Phi^T + Q = (I + G) (Phi_bd P Phi_bd^T + Q) (I + G)^T:
    the block products, then _couple_parameters' rank-one row and column updates.
    An empirical-acceleration block w (3) of spacecraft s has the diagonal m I and the coupling columns
    C = Phi[s, w]: Phi = (I + G) Phi_bd with G = C / m, and its process noise is coupled to s's. The caller
    passes Q~ = (I + G)^-1 Q (I + G)^-T in place of Q (estimation.process_noise.coupled_process_noise), so that
    (I + G) (Phi_bd P Phi_bd^T + Q~) (I + G)^T = Phi P Phi^T + Q exactly, with the same two steps.
    """
    n_blocks = block_kind.shape[0]
    # The leading spacecraft blocks sit at 6 a: offsets the compiler can see are non-negative multiples
    # of 6 make this hot path ~1.5x faster than offsets read from block_start.
    n_sc = 0
    while n_sc < n_blocks and block_kind[n_sc] == BLOCK_SPACECRAFT and block_start[n_sc] == 6 * n_sc:
        n_sc += 1
    for a in range(n_sc):
        ra = 6 * a
        for b in range(a, n_sc):
            rb = 6 * b
            for i in range(6):  # tmp = Phi_a P[a, b]
                for j in range(6):
                    acc = 0.0
                    for k in range(6):
                        acc += Phi[ra + i, ra + k] * P[ra + k, rb + j]
                    tmp[i, j] = acc
            for i in range(6):  # out[a, b] = tmp Phi_b^T + Q[a, b]
                j0 = i if a == b else 0
                for j in range(j0, 6):
                    acc = Q[ra + i, rb + j]
                    for k in range(6):
                        acc += tmp[i, k] * Phi[rb + j, rb + k]
                    out[ra + i, rb + j] = acc
                    out[rb + j, ra + i] = acc
    if n_sc == n_blocks:
        return out
    for a in range(n_blocks):
        ra, na, const_a = block_start[a], block_size[a], _identity_transition(block_kind[a])
        for b in range(max(a, n_sc), n_blocks):
            rb, nb, const_b = block_start[b], block_size[b], _identity_transition(block_kind[b])
            for i in range(na):  # tmp = Phi_a P[a, b]
                for j in range(nb):
                    if const_a:
                        tmp[i, j] = P[ra + i, rb + j]
                    else:
                        acc = 0.0
                        for k in range(na):
                            acc += Phi[ra + i, ra + k] * P[ra + k, rb + j]
                        tmp[i, j] = acc
            for i in range(na):  # out[a, b] = tmp Phi_b^T + Q[a, b]
                j0 = i if a == b else 0
                for j in range(j0, nb):
                    acc = Q[ra + i, rb + j]
                    if const_b:
                        acc += tmp[i, j]
                    else:
                        for k in range(nb):
                            acc += tmp[i, k] * Phi[rb + j, rb + k]
                    out[ra + i, rb + j] = acc
                    out[rb + j, ra + i] = acc
    _couple_parameters(out, Phi, block_kind, block_start)
    return out


@njit(cache=True, inline="always")
def _identity_transition(kind):
    return kind == BLOCK_CONSTANT or kind == BLOCK_PARAMETER


@njit(cache=True, inline="always")
def _couple_parameters(M, Phi, block_kind, block_start):
    """M <- (I + G) M (I + G)^T in place for every column p of a parameter or empirical-acceleration block and
    spacecraft block s whose coupling column gamma = Phi[s : s + 6, p] / Phi[p, p] is non-zero
    (predict_covariance_into; columns one at a time: G's columns never meet a spacecraft row of another G, so
    the products commute): first rows s += gamma M[p, :]
    (row p itself is not in s, so it is read unchanged), then columns s += M[:, p] gamma^T, reading column p as
    the row step left it (its entries in rows s now include gamma M[p, p]), which is (I + G) M's."""
    n = M.shape[0]
    for q in range(block_kind.shape[0]):
        if block_kind[q] == BLOCK_PARAMETER:
            columns = 1
        elif block_kind[q] == BLOCK_EMPIRICAL:
            columns = 3
        else:
            continue
        for c in range(columns):
            p = block_start[q] + c
            diagonal = Phi[p, p]  # 1 for a parameter; an empirical acceleration's decay m: G = Phi[s, p] / m
            for b in range(block_kind.shape[0]):
                s = block_start[b]
                if block_kind[b] != BLOCK_SPACECRAFT or not _couples(Phi, s, p):
                    continue
                for i in range(6):
                    g = Phi[s + i, p] / diagonal
                    for j in range(n):
                        M[s + i, j] += g * M[p, j]
                for i in range(6):
                    g = Phi[s + i, p] / diagonal
                    for j in range(n):
                        M[j, s + i] += M[j, p] * g


@njit(cache=True, inline="always")
def _couples(Phi, s, p):
    """True if column p of Phi reaches the spacecraft block at s (any of its six rows non-zero)."""
    for i in range(6):
        if Phi[s + i, p] != 0.0:
            return True
    return False


@njit(cache=True)
def normalized_error_squared(e, P, work):
    """NEES e^T P^-1 e by an in-place Cholesky factor of P (no inverse).

    e (n,); P (n, n) symmetric positive definite; work (n, n) scratch. Returns NaN if P is not PD.
    """
    return nees_into(e, P, work, np.empty(e.shape[0]))


@njit(cache=True)
def nees_into(e, P, work, z):
    """normalized_error_squared with the caller's scratch: work (n, n) for L, z (n,) for L^-1 e."""
    n = e.shape[0]
    for j in range(n):  # work = L with P = L L^T (lower triangle)
        d = P[j, j]
        for k in range(j):
            d -= work[j, k] * work[j, k]
        if not d > 0.0:
            return np.nan
        d = np.sqrt(d)
        work[j, j] = d
        for i in range(j + 1, n):
            s = P[i, j]
            for k in range(j):
                s -= work[i, k] * work[j, k]
            work[i, j] = s / d
    total = 0.0
    for i in range(n):  # solve L z = e; NEES = |z|^2
        s = e[i]
        for k in range(i):
            s -= work[i, k] * z[k]
        z[i] = s / work[i, i]
        total += z[i] * z[i]
    return total


@njit(cache=True, inline="always")
def scalar_gain_into(h, hph, R, n_gain, underweight, K):
    """K (n,) = P H^T ((1 + beta) H P H^T + R)^-1 from h = P H^T and hph = H P H^T (Eq. 21; beta = underweight,
    see update_scalar), zero from n_gain on (consider states; n_gain < 0: none)."""
    denominator = (1.0 + underweight) * hph + R
    for i in range(h.shape[0]):
        K[i] = 0.0 if (n_gain >= 0 and i >= n_gain) else h[i] / denominator


@njit(cache=True)
def update_scalar(dx, P, y, H, R, n_gain=-1, underweight=0.0):
    """One scalar measurement update in Joseph form.

    dx (n,): state correction accumulated so far (relative to the linearisation point);
    P (n, n); y: pre-fit residual Y - G(X*); H (n,): partials at X*; R: variance.
    Returns (dx (n,), P (n, n), innovation, S) where innovation = y - H dx and S = H P H^T + R.

    Joseph form P+ = (I - K H) P (I - K H)^T + K R K^T (cf. Eq. 23), evaluated without forming I - K H:
    with h = P H^T and A = P - K h^T, P+ = A - (h - K (S - R)) K^T + R K K^T, which is the same
    product regrouped (valid for any gain K), in O(n^2) instead of two n x n matrix products.

    n_gain >= 0: only the first n_gain states are estimated; the rest are consider parameters whose gain
    is set to zero (Schmidt-Kalman). Their covariance still enters S and, through the Joseph form (valid
    for this suboptimal gain), the estimated states' covariance: the consider covariance.

    underweight = beta > 0: Lear's underweighting, K = P H^T ((1 + beta) H P H^T + R)^-1. While the a-priori
    spread H P H^T dwarfs R (a large initial error against a precise measurement), the full gain would trust
    a linearisation that is not yet good; the smaller gain takes a fraction of the step and the Joseph form
    keeps P honest for it. Once H P H^T << R the factor no longer matters.
    """
    n = dx.shape[0]
    new_dx = np.empty(n)
    P_new = np.empty((n, n))
    innovation, S = update_scalar_into(dx, P, y, H, R, n_gain, underweight, new_dx, P_new, np.empty(n), np.empty(n))
    return new_dx, P_new, innovation, S


@njit(cache=True)
def update_scalar_into(dx, P, y, H, R, n_gain, underweight, dx_out, P_out, h, K):
    """update_scalar written into dx_out (n,) and P_out (n, n) (neither may alias dx or P), with h, K (n,) the
    caller's scratch, left holding P H^T and the gain; returns (innovation, S). No allocation: the filter loops
    call it at every channel. The same two steps as prefit_into then apply_update_into (a residual gate
    calls them apart, deciding between them)."""
    innovation, S = prefit_into(dx, P, y, H, R, h)
    apply_update_into(dx, P, innovation, S, R, n_gain, underweight, dx_out, P_out, h, K)
    return innovation, S


@njit(cache=True, inline="always")
def prefit_into(dx, P, y, H, R, h):
    """The pre-fit innovation of one scalar measurement and its variance, before any update with it:
    innovation = y - H dx and S = H P H^T + R (the innovation covariance: the denominator of the gain, Eq. 21;
    Tapley, Schutz & Born 2004 §4.7), h (n,) <- P H^T for apply_update_into. Returns (innovation, S)."""
    n = dx.shape[0]
    S = R
    innovation = y
    for i in range(n):  # h = P H^T, S = H P H^T + R, innovation = y - H dx
        acc = 0.0
        for j in range(n):
            acc += P[i, j] * H[j]
        h[i] = acc
        S += H[i] * acc
        innovation -= H[i] * dx[i]
    return innovation, S


@njit(cache=True, inline="always")
def apply_update_into(dx, P, innovation, S, R, n_gain, underweight, dx_out, P_out, h, K):
    """The update with one scalar measurement from prefit_into's innovation, S and h = P H^T: gain (Eq. 21)
    into K, dx_out = dx + K innovation (Eq. 22) and the Joseph-form P_out (update_scalar)."""
    n = dx.shape[0]
    hs = S - R
    scalar_gain_into(h, hs, R, n_gain, underweight, K)  # Eq. 21
    for i in range(n):
        dx_out[i] = dx[i] + K[i] * innovation  # Eq. 22, sequential form
        u_i = h[i] - K[i] * hs
        for j in range(n):
            P_out[i, j] = P[i, j] - K[i] * h[j] - u_i * K[j] + R * K[i] * K[j]
    for i in range(n):
        for j in range(i + 1, n):
            sym = 0.5 * (P_out[i, j] + P_out[j, i])
            P_out[i, j] = sym
            P_out[j, i] = sym
