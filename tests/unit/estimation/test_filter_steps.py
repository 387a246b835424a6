"""The named steps of the compiled EKF and LinCov loops (filter_loop, lincov), called on their own: the
health checks, the epoch record, and LinCov's dynamics mismatch, against numpy."""

import numpy as np

from liaison_cli.estimation.blocks import BLOCK_CLOCK, BLOCK_CONSTANT, BLOCK_SPACECRAFT
from liaison_cli.estimation.filter_loop import (
    STATUS_COVARIANCE_NOT_POSITIVE,
    STATUS_NONFINITE,
    STATUS_OK,
    covariance_health,
    position_beyond_bound,
    record_epoch,
)
from liaison_cli.estimation.kernel_args import BlockLayout
from liaison_cli.estimation.lincov import _dynamics_mismatch

# One spacecraft (6), a two-state clock, a range bias: n = 9.
LAYOUT = BlockLayout(np.array([BLOCK_SPACECRAFT, BLOCK_CLOCK, BLOCK_CONSTANT]), np.array([0, 6, 8]),
                     np.array([6, 2, 1]), np.array([-1, -1, -1]))


def _spd(n, seed=0):
    a = np.random.default_rng(seed).normal(size=(n, n))
    return a @ a.T + n * np.eye(n)


def test_covariance_health_names_each_failure():
    x, P = np.ones(9), _spd(9)
    assert covariance_health(x, P) == STATUS_OK
    x_nan = x.copy()
    x_nan[3] = np.nan
    assert covariance_health(x_nan, P) == STATUS_NONFINITE
    P_inf = P.copy()
    P_inf[8, 8] = np.inf
    assert covariance_health(x, P_inf) == STATUS_NONFINITE
    P_negative = P.copy()
    P_negative[7, 7] = -1e-3
    assert covariance_health(x, P_negative) == STATUS_COVARIANCE_NOT_POSITIVE


def test_only_a_spacecraft_position_error_counts_against_the_bound():
    e = np.zeros(9)
    e[6] = e[8] = 10.0  # clock and bias errors far beyond the bound: not positions
    assert not position_beyond_bound(e, LAYOUT, 1.0)
    e[:3] = [0.6, 0.6, 0.6]  # |r| = 1.04 > 1
    assert position_beyond_bound(e, LAYOUT, 1.0)
    assert not position_beyond_bound(e, LAYOUT, 1.1)


def test_record_epoch_writes_error_sigma_and_nees():
    rng = np.random.default_rng(1)
    m, n, n_nees, k = 4, 9, 6, 2
    x_hat, truth, P = rng.normal(size=n), rng.normal(size=(m, n)), _spd(n, 2)
    err, sig, nees = np.full((m, n), np.nan), np.full((m, n), np.nan), np.full(m, np.nan)
    e = np.empty(n)
    record_epoch(k, x_hat, truth, P, n_nees, e, err, sig, nees, np.empty((n_nees, n_nees)), np.empty(n_nees))
    want = x_hat - truth[k]
    np.testing.assert_array_equal(err[k], want)
    np.testing.assert_array_equal(e, want)
    np.testing.assert_array_equal(sig[k], np.sqrt(np.diag(P)))
    block = want[:n_nees]
    assert np.isclose(nees[k], block @ np.linalg.solve(P[:n_nees, :n_nees], block), rtol=1e-12)
    assert np.isnan(err[k - 1]).all() and np.isnan(nees[k + 1])  # other epochs untouched


def test_lincov_dynamics_mismatch_keeps_only_stated_drifts_off_the_spacecraft():
    rng = np.random.default_rng(3)
    truth_k, x_bar, extra = rng.normal(size=9), rng.normal(size=9), rng.normal(size=9)
    Phi = np.zeros((9, 9))
    d_dyn = _dynamics_mismatch(truth_k, x_bar, extra, Phi, LAYOUT)
    np.testing.assert_array_equal(d_dyn[:6], truth_k[:6] - x_bar[:6] + extra[:6])
    np.testing.assert_array_equal(d_dyn[6:], extra[6:])
    assert Phi[8, 8] == 1.0 and np.count_nonzero(Phi) == 1  # identity on the constant block only
