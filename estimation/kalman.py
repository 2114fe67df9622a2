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

``method="doubling"`` (default) solves the DARE with the structure-preserving
doubling algorithm of :func:`solve_filter_dare` (numpy only, about 20 times
faster than the QZ-based solvers on the paper's order-4 model);
``method="scipy"`` calls ``scipy.linalg.solve_discrete_are`` and
``method="control"`` calls ``control.dlqe``. All three give the same gains
(tested to 1e-9 relative on the paper's model and on random systems).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg
from scipy.linalg.lapack import dgesv, dpotrf

from estimation.errors import RiccatiError

if TYPE_CHECKING:
    pass

KALMAN_METHODS = ("doubling", "scipy", "control")

#: Relative change of the doubling iterate below which it has converged. The
#: increment shrinks like ``rho^(2^k)`` (``rho`` = spectral radius of the
#: filter's ``A - L C``): once it is below 1e-14 the next one is below rounding.
DOUBLING_TOL = 1e-14
#: Doubling steps allowed: 2^60 Riccati steps, enough for any ``rho < 1 - 1e-15``.
DOUBLING_MAX_ITER = 60


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


def solve_filter_dare(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray,
    *,
    tol: float = DOUBLING_TOL,
    max_iter: int = DOUBLING_MAX_ITER,
) -> np.ndarray:
    """Stabilizing solution of the filter DARE by structure-preserving doubling.

    Solves ``P = A P A^T - A P C^T (C P C^T + R)^-1 C P A^T + Q`` (paper eq. 18 at
    its fixed point), written as ``P = A P (I + G P)^-1 A^T + Q`` with
    ``G = C^T R^-1 C`` (push-through identity). The structure-preserving
    doubling algorithm (SDA-1 of Chu, Fan and Lin, 2005, for the dual control
    equation) starts from ``A_0 = A^T``, ``G_0 = G``, ``H_0 = Q`` and iterates::

        W_k     = I + G_k H_k
        A_{k+1} = A_k W_k^-1 A_k
        G_{k+1} = G_k + A_k W_k^-1 G_k A_k^T
        H_{k+1} = H_k + A_k^T H_k W_k^-1 A_k

    ``H_k`` equals the Riccati difference equation started at ``P = Q`` after
    ``2^k`` steps, so it converges quadratically to ``P``:
    ``||H_{k+1} - H_k|| = O(rho^(2^(k+1)))`` with ``rho`` the spectral radius of
    the filter's closed loop ``A - L C``. One LU solve of ``W_k`` serves both
    ``W_k^-1 A_k`` and ``W_k^-1 G_k``.

    Parameters
    ----------
    A : ndarray, shape (n_states, n_states)
    C : ndarray, shape (n_outputs, n_states)
    Q : ndarray, shape (n_states, n_states)
        Symmetric positive semidefinite.
    R : ndarray, shape (n_outputs, n_outputs)
        Symmetric positive definite.
    tol : float
        Convergence when ``max |H_{k+1} - H_k| <= tol max |H_{k+1}|`` (entrywise).
    max_iter : int
        Doubling steps allowed (each doubles the Riccati horizon).

    Returns
    -------
    ndarray, shape (n_states, n_states)
        ``P``, symmetrized.

    Raises
    ------
    RiccatiError
        ``W_k`` singular, a non-finite iterate (an unstable mode that is not
        observable: the iterates grow without bound), or no convergence within
        ``max_iter`` steps (a closed-loop pole on the unit circle). The caller
        checks that the solution is stabilizing.
    """
    n = A.shape[0]
    eye = np.eye(n)
    Ak = np.ascontiguousarray(A.T)
    Gk = C.T.dot(dgesv(R, C)[2])
    Gk = 0.5 * (Gk + Gk.T)
    Hk = np.array(Q, dtype=np.float64)
    rhs = np.empty((n, 2 * n))
    change = size = np.inf
    # The 4 x 4 products go through ndarray.dot and the LU solve straight to
    # LAPACK's dgesv: numpy's generic wrappers cost more than the arithmetic.
    with np.errstate(over="ignore", invalid="ignore"):
        for _ in range(max_iter):
            W = eye + Gk.dot(Hk)
            rhs[:, :n] = Ak
            rhs[:, n:] = Gk
            _, _, WAG, info = dgesv(W, rhs)
            if info != 0:
                raise RiccatiError(
                    f"doubling: I + G_k H_k is singular (LAPACK dgesv info {info}); the "
                    "Riccati equation has no stabilizing solution"
                )
            WA, WG = WAG[:, :n], WAG[:, n:]
            dH = Ak.T.dot(Hk.dot(WA))
            Gk = Gk + Ak.dot(WG).dot(Ak.T)
            Ak = Ak.dot(WA)
            Hk = Hk + dH
            # H_k is positive semidefinite: its largest entry is on the diagonal.
            size = float(Hk.diagonal().max())
            change = float(abs(dH).max())
            if not (math.isfinite(size) and math.isfinite(change)):
                raise RiccatiError(
                    "doubling: the iterates diverged (an unstable mode that is not "
                    "observable or not excited by the noise); no stabilizing solution"
                )
            if change <= tol * size:
                return 0.5 * (Hk + Hk.T)
    raise RiccatiError(
        f"doubling: no convergence in {max_iter} steps (last relative change "
        f"{change / max(size, np.finfo(float).tiny):.3g}, expected <= {tol:g}); a closed-loop "
        "pole on the unit circle, no stabilizing solution"
    )


def design_kalman(
    A: np.ndarray,
    C: np.ndarray,
    Q: np.ndarray,
    R: np.ndarray | float,
    *,
    method: str = "doubling",
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
    method : {"doubling", "scipy", "control"}
        Riccati solver: :func:`solve_filter_dare` (default),
        ``scipy.linalg.solve_discrete_are`` or ``control.dlqe``.

    Raises
    ------
    RiccatiError
        No stabilizing solution (e.g. an unstable mode that is unobservable or
        not excited by the noise), ``R`` not positive definite, or bad shapes.
    """
    import control
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
    if not (np.isfinite(A).all() and np.isfinite(Q).all() and np.isfinite(R).all()):
        raise RiccatiError("A, Q and R must be finite; found NaN or inf")
    # Cholesky (LAPACK dpotrf) succeeds exactly when R is positive definite.
    if dpotrf(0.5 * (R + R.T))[1] != 0:
        raise RiccatiError(
            f"R must be positive definite, found eigenvalues {np.linalg.eigvalsh(R)}"
        )
    Q = 0.5 * (Q + Q.T)
    try:
        if method == "doubling":
            P = solve_filter_dare(A, C, Q, R)
        elif method == "scipy":
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
    CP = C.dot(P)
    K = dgesv(CP.dot(C.T) + R, CP)[2].T  # P C^T S^-1, S = C P C^T + R (S and P symmetric)
    L = A.dot(K)
    poles = np.linalg.eigvals(A - L @ C)
    if not np.all(np.isfinite(P)) or np.max(np.abs(poles)) >= 1.0:
        raise RiccatiError(
            f"the Riccati solution is not stabilizing: max |eig(A - L C)| = "
            f"{np.max(np.abs(poles)):.6g}, expected < 1"
        )
    return SteadyStateKalman(predictor_gain=L, filter_gain=K, P=P, Q=Q, R=R, poles=poles)
