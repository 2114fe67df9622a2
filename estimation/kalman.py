"""Steady-state Kalman filter design for an identified model (paper eqs. 17-21).

For ``x(k) = A x(k-1) + B u(k-1) + Gamma w(k-1)``, ``y(k) = C x(k) + v(k)`` with
``Q = Gamma diag(sigma_w^2) Gamma^T`` and ``R = diag(sigma_v^2)``, the a priori
covariance ``P`` solves the discrete algebraic Riccati equation (eq. 18 at its
fixed point) and

- the **predictor gain** ``L = A P C^T (C P C^T + R)^-1`` (eq. 17; what
  ``control.dlqe`` returns) drives the paper's estimator
  ``xhat(k) = (A - L C) xhat(k-1) + B u(k-1) + L y(k-1)`` (eq. 16);
- the **filter gain** ``K = P C^T (C P C^T + R)^-1`` (``L = A K``) gives the
  a posteriori update ``xhat(k|k) = xhat(k|k-1) + K (y(k) - C xhat(k|k-1))``.

``method="scipy"`` (default, faster) solves the DARE with
``scipy.linalg.solve_discrete_are``; ``method="control"`` calls
``control.dlqe``. Both give the same gains (tested to 1e-8).
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np
import scipy.linalg

from estimation.errors import RiccatiError

KALMAN_METHODS = ("scipy", "control")


@dataclass(frozen=True)
class SteadyStateKalman:
    """Steady-state Kalman design.

    Attributes
    ----------
    predictor_gain : ndarray, shape (n_states, n_outputs)
        ``L = A P C^T (C P C^T + R)^-1``.
    filter_gain : ndarray, shape (n_states, n_outputs)
        ``K = P C^T (C P C^T + R)^-1``.
    P : ndarray, shape (n_states, n_states)
        A priori error covariance (DARE solution), symmetric.
    Q : ndarray, shape (n_states, n_states)
        Process-noise covariance that entered the Riccati equation.
    R : ndarray, shape (n_outputs, n_outputs)
        Measurement-noise covariance.
    poles : ndarray, shape (n_states,)
        Eigenvalues of ``A - L C`` (all inside the unit circle).
    """

    predictor_gain: np.ndarray
    filter_gain: np.ndarray
    P: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    poles: np.ndarray


def process_noise_covariance(gamma: np.ndarray, sigma_w2: np.ndarray) -> np.ndarray:
    """``Q = Gamma diag(sigma_w^2) Gamma^T`` (eq. 20), symmetrized exactly.

    Parameters
    ----------
    gamma : ndarray, shape (n_states, n_noise)
    sigma_w2 : ndarray, shape (n_noise,)
        Process-noise variances.
    """
    gamma = np.atleast_2d(np.asarray(gamma, dtype=np.float64))
    q = (gamma * np.asarray(sigma_w2, dtype=np.float64)) @ gamma.T
    return 0.5 * (q + q.T)


def design_kalman(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray | float,
    *,
    method: str = "scipy",
) -> SteadyStateKalman:
    """Steady-state Kalman gains from the discrete algebraic Riccati equation.

    Parameters
    ----------
    A : ndarray, shape (n_states, n_states)
    C : ndarray, shape (n_outputs, n_states)
    Q : ndarray, shape (n_states, n_states)
        Process-noise covariance (symmetric, positive semidefinite).
    R : ndarray, shape (n_outputs, n_outputs), or float
        Measurement-noise covariance (positive definite).
    method : {"scipy", "control"}

    Raises
    ------
    RiccatiError
        No stabilizing solution (e.g. an unstable mode that is unobservable or
        not excited by the noise), ``R`` not positive definite, or bad shapes.
    """
    A = np.atleast_2d(np.asarray(A, dtype=np.float64))
    C = np.atleast_2d(np.asarray(C, dtype=np.float64))
    Q = np.atleast_2d(np.asarray(Q, dtype=np.float64))
    R = np.atleast_2d(np.asarray(R, dtype=np.float64))
    n = A.shape[0]
    if A.shape != (n, n) or C.shape[1] != n or Q.shape != (n, n) or R.shape != (C.shape[0],) * 2:
        raise RiccatiError(
            f"inconsistent shapes: A {A.shape}, C {C.shape}, Q {Q.shape}, R {R.shape}; "
            "expected A (n, n), C (p, n), Q (n, n), R (p, p)"
        )
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(Q)) and np.all(np.isfinite(R))):
        raise RiccatiError("A, Q and R must be finite; found NaN or inf")
    if np.linalg.eigvalsh(0.5 * (R + R.T)).min() <= 0:
        raise RiccatiError(
            f"R must be positive definite, found eigenvalues {np.linalg.eigvalsh(R)}"
        )
    Q = 0.5 * (Q + Q.T)
    try:
        if method == "scipy":
            P = scipy.linalg.solve_discrete_are(A.T, C.T, Q, R, balanced=False)
        elif method == "control":
            _, P, _ = control.dlqe(A, np.eye(n), C, Q, R)
            P = np.asarray(P)
        else:
            raise RiccatiError(f"method must be one of {KALMAN_METHODS}, found {method!r}")
    except (np.linalg.LinAlgError, ValueError, ArithmeticError) as exc:
        if isinstance(exc, RiccatiError):
            raise
        raise RiccatiError(
            f"the Riccati equation has no stabilizing solution ({str(exc).splitlines()[0]})"
        ) from exc
    P = 0.5 * (P + P.T)
    S = C @ P @ C.T + R
    K = np.linalg.solve(S, C @ P).T  # P C^T S^-1 (S and P symmetric)
    L = A @ K
    poles = np.linalg.eigvals(A - L @ C)
    if not np.all(np.isfinite(P)) or np.max(np.abs(poles)) >= 1.0:
        raise RiccatiError(
            f"the Riccati solution is not stabilizing: max |eig(A - L C)| = "
            f"{np.max(np.abs(poles)):.6g}, expected < 1"
        )
    return SteadyStateKalman(predictor_gain=L, filter_gain=K, P=P, Q=Q, R=R, poles=poles)
