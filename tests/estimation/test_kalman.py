"""Steady-state Kalman design: closed forms, independent Riccati solutions, failures."""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg

from estimation.errors import RiccatiError
from estimation.kalman import design_kalman, process_noise_covariance, solve_filter_dare


def scalar_riccati(a: float, q: float, r: float) -> float:
    """Positive root of p^2 + p (r (1 - a^2) - q) - q r = 0 (DARE with c = g = 1)."""
    beta = r * (1.0 - a * a) - q
    return 0.5 * (-beta + np.sqrt(beta * beta + 4.0 * q * r))


@pytest.mark.parametrize("a,q,r", [(0.9, 0.1, 1.0), (1.2, 0.5, 0.2), (-0.5, 2.0, 3.0)])
@pytest.mark.parametrize("method", ["doubling", "scipy", "control"])
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


# ------------------------------------------------------- doubling DARE solver
def _paper_model() -> tuple[np.ndarray, ...]:
    """The SS_KF model identified on virtual subject 1's calibration (order 4, 9 inputs)."""
    from estimation.features import extract_features
    from estimation.registry import make_estimator
    from sim.user.subjects import make_population

    subject = make_population(n=1, seed=0)[0]
    fs = extract_features(subject.paper_session(rng=np.random.default_rng(0)))
    n_id = fs.n_windows // 2
    est = make_estimator("ss_kf", order=4).fit(fs.X[:n_id], fs.y[:n_id]).estimator
    return est.A_, est.C_, est.Q_, est.R_


def _assert_same_design(a, b, rtol: float = 1e-9) -> None:
    for name in ("P", "filter_gain", "predictor_gain"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.abs(x - y).max() <= rtol * np.abs(y).max(), name


def test_doubling_equals_scipy_dare_on_the_paper_model() -> None:
    A, C, Q, R = _paper_model()
    doubling = design_kalman(A, C, Q, R, method="doubling")
    reference = design_kalman(A, C, Q, R, method="scipy")
    _assert_same_design(doubling, reference)
    # the DARE itself holds to rounding
    P = doubling.P
    S = C @ P @ C.T + R
    residual = A @ P @ A.T - A @ P @ C.T @ np.linalg.solve(S, C @ P @ A.T) + Q - P
    assert np.abs(residual).max() <= 1e-12 * np.abs(P).max()


@pytest.mark.parametrize("seed", range(12))
def test_doubling_equals_scipy_dare_on_random_detectable_systems(seed: int) -> None:
    """Stable and unstable A (spectral radius 0.3-1.3), 1-6 states, 1-2 outputs."""
    rng = np.random.default_rng(100 + seed)
    n, p = int(rng.integers(1, 7)), int(rng.integers(1, 3))
    A = rng.normal(size=(n, n))
    A *= rng.uniform(0.3, 1.3) / max(abs(np.linalg.eigvals(A)))
    gamma = rng.normal(size=(n, n))
    Q = process_noise_covariance(gamma, rng.uniform(0.01, 0.1, n))
    C = rng.normal(size=(p, n))
    R = np.diag(rng.uniform(0.01, 1.0, p))
    _assert_same_design(design_kalman(A, C, Q, R, method="doubling"),
                        design_kalman(A, C, Q, R, method="scipy"))


def test_doubling_is_the_default() -> None:
    A, gamma, sigma_w2, C, R = _random_model(3)
    Q = process_noise_covariance(gamma, sigma_w2)
    default = design_kalman(A, C, Q, R)
    assert np.array_equal(default.P, design_kalman(A, C, Q, R, method="doubling").P)


def test_doubling_reports_divergence_as_riccati_error() -> None:
    """An unstable mode the output cannot see: the iterates grow without bound."""
    with pytest.raises(RiccatiError, match="doubling: the iterates diverged"):
        solve_filter_dare(np.diag([1.5, 0.5]), np.array([[0.0, 1.0]]), np.eye(2),
                          np.array([[1.0]]))


def test_doubling_reports_no_convergence_as_riccati_error() -> None:
    """A unit-circle mode the output cannot see: the iterates never settle."""
    with pytest.raises(RiccatiError, match="doubling: no convergence"):
        solve_filter_dare(np.diag([1.0, 0.5]), np.array([[0.0, 1.0]]), np.eye(2),
                          np.array([[1.0]]), max_iter=30)
    with pytest.raises(RiccatiError, match="stabilizing"):
        design_kalman(np.diag([1.0, 0.5]), np.array([[0.0, 1.0]]), np.eye(2), [[1.0]])
