"""RLS identification: golden batch solution, covariance health, difference states."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.errors import EstimationInputError
from estimation.rls import difference_states, difference_transform, rls


def test_rls_without_noise_regressor_equals_regularized_batch_solution() -> None:
    rng = np.random.default_rng(1)
    Phi = rng.normal(size=(400, 7))
    Y = Phi @ rng.normal(size=(7, 3)) + 0.1 * rng.normal(size=(400, 3))
    res = rls(Phi, Y, noise_regressor=False, forgetting=1.0, theta0=0.3, p0=1000.0)
    P0_inv = np.eye(7) / 1000.0
    info = P0_inv + Phi.T @ Phi
    theta_batch = np.linalg.solve(info, P0_inv @ np.full((7, 3), 0.3) + Phi.T @ Y)
    np.testing.assert_allclose(res.theta, theta_batch, rtol=0, atol=1e-8)
    np.testing.assert_allclose(res.P, np.linalg.inv(info), rtol=1e-8, atol=1e-12)


def test_prior_and_posterior_errors_are_consistent_with_final_parameters() -> None:
    rng = np.random.default_rng(2)
    Phi = rng.normal(size=(50, 4))
    Y = rng.normal(size=(50, 2))
    res = rls(Phi, Y, noise_regressor=False)
    # last row: a posteriori residual uses theta(N), which is the final theta
    np.testing.assert_allclose(res.residuals[-1], Y[-1] - Phi[-1] @ res.theta, atol=1e-10)


def test_covariance_stays_symmetric_and_positive_definite_with_forgetting() -> None:
    rng = np.random.default_rng(3)
    n_rows = 20_000
    Phi = rng.normal(size=(n_rows, 6))
    Y = Phi[:, :2] @ np.array([[0.5, -0.2], [0.1, 0.4]]) + 0.05 * rng.normal(size=(n_rows, 2))
    res = rls(Phi, Y, noise_regressor=True, forgetting=0.98)
    assert np.array_equal(res.P, res.P.T)
    eig = np.linalg.eigvalsh(res.P)
    assert eig.min() > 0 and np.all(np.isfinite(eig))
    # with forgetting the estimate tracks the true coefficients of the fixed regressors
    np.testing.assert_allclose(res.theta[:2, :], [[0.5, -0.2], [0.1, 0.4]], atol=0.05)


def test_difference_states_match_hand_computed_differences() -> None:
    y = np.arange(6.0) ** 2  # 0 1 4 9 16 25
    X = difference_states(y, 3, 0.5)
    # x2(k) = (y(k) - y(k-1)) / 0.5, x3(k) = (x2(k) - x2(k-1)) / 0.5; y(-1) = y(-2) = 0
    np.testing.assert_allclose(X[:, 0], y)
    np.testing.assert_allclose(X[:, 1], [0, 2, 6, 10, 14, 18])
    np.testing.assert_allclose(X[:, 2], [0, 4, 8, 8, 8, 8])
    T = difference_transform(3, 0.5)
    np.testing.assert_allclose(T, [[1, 0, 0], [2, -2, 0], [4, -8, 4]])


@pytest.mark.parametrize("kw", [{"forgetting": 0.0}, {"forgetting": 1.5}, {"p0": -1.0}])
def test_bad_hyperparameters_are_rejected(kw: dict) -> None:
    with pytest.raises(EstimationInputError):
        rls(np.ones((5, 2)), np.ones((5, 1)), **kw)


def test_mismatched_rows_are_rejected() -> None:
    with pytest.raises(EstimationInputError, match="share rows"):
        rls(np.ones((5, 2)), np.ones((4, 1)))
