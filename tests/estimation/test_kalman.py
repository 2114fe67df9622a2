"""Steady-state Kalman design: closed forms, independent Riccati solutions, failures."""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg

from estimation.errors import RiccatiError
from estimation.kalman import design_kalman, process_noise_covariance


def scalar_riccati(a: float, q: float, r: float) -> float:
    """Positive root of p^2 + p (r (1 - a^2) - q) - q r = 0 (DARE with c = g = 1)."""
    beta = r * (1.0 - a * a) - q
    return 0.5 * (-beta + np.sqrt(beta * beta + 4.0 * q * r))


@pytest.mark.parametrize("a,q,r", [(0.9, 0.1, 1.0), (1.2, 0.5, 0.2), (-0.5, 2.0, 3.0)])
@pytest.mark.parametrize("method", ["scipy", "control"])
def test_scalar_gain_matches_closed_form(a: float, q: float, r: float, method: str) -> None:
    p = scalar_riccati(a, q, r)
    kf = design_kalman([[a]], [[1.0]], [[q]], r, method=method)
    assert kf.P[0, 0] == pytest.approx(p, rel=1e-10)
    assert kf.predictor_gain[0, 0] == pytest.approx(a * p / (p + r), rel=1e-10)
    assert kf.filter_gain[0, 0] == pytest.approx(p / (p + r), rel=1e-10)
    assert abs(kf.poles[0]) < 1


def _random_model(seed: int, n: int = 4):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A *= 0.95 / max(abs(np.linalg.eigvals(A)))
    gamma = rng.normal(size=(n, n))
    sigma_w2 = rng.uniform(0.01, 0.1, size=n)
    C = np.eye(1, n)
    return A, gamma, sigma_w2, C, np.array([[0.05]])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_predictor_gain_equals_independent_dare_solution(seed: int) -> None:
    A, gamma, sigma_w2, C, R = _random_model(seed)
    Q = process_noise_covariance(gamma, sigma_w2)
    kf = design_kalman(A, C, Q, R)
    # independent: scipy's DARE on the dual problem, gain assembled by hand
    P = scipy.linalg.solve_discrete_are(A.T, C.T, Q, R, balanced=False)
    L_ref = A @ P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    np.testing.assert_allclose(kf.predictor_gain, L_ref, rtol=0, atol=1e-8)
    # python-control returns the predictor gain for (A, Gamma, C, diag(sigma_w^2), R)
    L_ctrl, _, _ = control.dlqe(A, gamma, C, np.diag(sigma_w2), R)
    np.testing.assert_allclose(kf.predictor_gain, np.asarray(L_ctrl), rtol=0, atol=1e-8)
    np.testing.assert_allclose(kf.predictor_gain, A @ kf.filter_gain, atol=1e-12)


def test_gain_equals_limit_of_the_riccati_difference_equation() -> None:
    """Paper eq. (18) iterated from a large P(0) converges to the DARE gain."""
    A, gamma, sigma_w2, C, R = _random_model(5)
    Q = process_noise_covariance(gamma, sigma_w2)
    P = 1e3 * np.eye(4)
    for _ in range(5000):
        S = C @ P @ C.T + R
        P = A @ P @ A.T - A @ P @ C.T @ np.linalg.solve(S, C @ P @ A.T) + Q
    L_iter = A @ P @ C.T @ np.linalg.inv(C @ P @ C.T + R)
    kf = design_kalman(A, C, Q, R, method="control")
    np.testing.assert_allclose(kf.predictor_gain, L_iter, atol=1e-8)


def test_process_noise_covariance_is_symmetric_gamma_diag_gamma_t() -> None:
    rng = np.random.default_rng(7)
    gamma = rng.normal(size=(3, 3)) * 1e3
    s = np.array([1e-3, 2.0, 0.5])
    Q = process_noise_covariance(gamma, s)
    assert np.array_equal(Q, Q.T)
    np.testing.assert_allclose(Q, gamma @ np.diag(s) @ gamma.T, rtol=1e-12)


def test_unstable_unobservable_mode_has_no_stabilizing_solution() -> None:
    A = np.diag([1.5, 0.5])
    C = np.array([[0.0, 1.0]])  # the unstable mode is invisible
    with pytest.raises(RiccatiError, match="stabilizing"):
        design_kalman(A, C, np.eye(2), [[1.0]])


def test_non_positive_measurement_noise_is_rejected() -> None:
    with pytest.raises(RiccatiError, match="positive definite"):
        design_kalman([[0.5]], [[1.0]], [[1.0]], [[0.0]])


def test_shape_mismatch_is_rejected() -> None:
    with pytest.raises(RiccatiError, match="inconsistent shapes"):
        design_kalman(np.eye(2), np.eye(1, 3), np.eye(2), [[1.0]])
