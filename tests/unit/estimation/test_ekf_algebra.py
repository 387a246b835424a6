"""The EKF algebra against textbook formulas: Joseph update, sequential scalar updates, block predict, NEES."""

import numpy as np
import pytest

from liaison_cli.estimation.ekf import (
    normalized_error_squared,
    predict_covariance_blocks,
    update_scalar,
)
from liaison_cli.estimation.blocks import BLOCK_CLOCK, BLOCK_CONSTANT, BLOCK_SPACECRAFT


def test_joseph_scalar_update_equals_textbook_kalman_update():
    rng = np.random.default_rng(1)
    a = rng.standard_normal((12, 12))
    P = a @ a.T + 12 * np.eye(12)
    H = rng.standard_normal(12)
    R = 0.7
    y = 1.3
    dx, P_new, innovation, S = update_scalar(np.zeros(12), P, y, H, R)
    K = P @ H / (H @ P @ H + R)  # Eq. 21
    assert np.allclose(dx, K * y)  # Eq. 22
    assert np.allclose(P_new, (np.eye(12) - np.outer(K, H)) @ P)  # Eq. 23 (optimal gain)
    assert S == pytest.approx(H @ P @ H + R)
    assert np.all(np.linalg.eigvalsh(P_new) > 0)


def test_sequential_scalar_updates_equal_one_batch_update():
    rng = np.random.default_rng(2)
    a = rng.standard_normal((6, 6))
    P = a @ a.T + np.eye(6)
    Hs = rng.standard_normal((2, 6))
    R = np.diag([0.5, 2.0])
    y = np.array([0.3, -1.1])
    dx = np.zeros(6)
    P_seq = P
    for i in range(2):
        dx, P_seq, _, _ = update_scalar(dx, P_seq, y[i], Hs[i], R[i, i])
    S = Hs @ P @ Hs.T + R
    K = P @ Hs.T @ np.linalg.inv(S)
    assert np.allclose(dx, K @ y)
    assert np.allclose(P_seq, (np.eye(6) - K @ Hs) @ P)


@pytest.mark.parametrize("blocks", [
    [(BLOCK_SPACECRAFT, 6)],
    [(BLOCK_SPACECRAFT, 6)] * 3,
    [(BLOCK_SPACECRAFT, 6), (BLOCK_SPACECRAFT, 6), (BLOCK_CLOCK, 2), (BLOCK_CLOCK, 3), (BLOCK_CONSTANT, 1)],
])
def test_block_predict_equals_full_product(blocks):
    rng = np.random.default_rng(len(blocks))
    kind = np.array([k for k, _ in blocks], dtype=np.int64)
    size = np.array([n for _, n in blocks], dtype=np.int64)
    start = np.concatenate([[0], np.cumsum(size)[:-1]]).astype(np.int64)
    n = int(size.sum())
    Phi = np.zeros((n, n))
    for k, a, b in zip(kind, start, size):
        Phi[a : a + b, a : a + b] = np.eye(b) if k == BLOCK_CONSTANT else rng.standard_normal((b, b))
    A = rng.standard_normal((n, n))
    P = A @ A.T + n * np.eye(n)
    Q = np.diag(rng.uniform(0.0, 1e-3, n))
    fast = predict_covariance_blocks(P, Phi, Q, np.empty((n, n)), kind, start, size)
    assert np.allclose(fast, Phi @ P @ Phi.T + Q, rtol=1e-13, atol=1e-12)
    assert np.array_equal(fast, fast.T)


def test_nees_by_cholesky_matches_solve_and_flags_indefinite():
    rng = np.random.default_rng(5)
    A = rng.standard_normal((12, 12))
    P = A @ A.T + 0.1 * np.eye(12)
    e = rng.standard_normal(12)
    assert normalized_error_squared(e, P, np.empty((12, 12))) == pytest.approx(e @ np.linalg.solve(P, e), rel=1e-10)
    P[3, 3] = -1.0
    assert np.isnan(normalized_error_squared(e, P, np.empty((12, 12))))
