"""Recursive least squares for the paper's state-space identification (eqs. 4-16).

The states are the force and its scaled backward differences (eq. 6)::

    x_1(k) = y(k),   x_{i+1}(k) = (x_i(k) - x_i(k-1)) / Ts

and the model ``x(k) = A x(k-1) + B u(k-1) + Gamma w(k-1)`` is identified row by
row with one shared covariance ``P`` because every state equation has the same
regressor ``phi(k) = [x(k-1); u(k-1); w(k-1)]`` (eq. 10). ``theta`` has shape
(2n + i, n) and equals ``[A B Gamma]^T``. ``w(k)`` is the a posteriori residual
``x(k) - phi(k)^T theta(k)`` (eq. 14), zero before the first update.

With ``w`` switched off and ``forgetting = 1`` the recursion equals the
regularized batch solution ``(P0^-1 + Phi^T Phi)^-1 (P0^-1 theta0 + Phi^T Y)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np
from scipy.linalg.blas import dger, dsymv, dsyr

from estimation.errors import EstimationInputError


def difference_transform(order: int, dt_s: float) -> np.ndarray:
    """Matrix ``T`` with ``x(k) = T @ [y(k), y(k-1), ..., y(k-order+1)]`` (eq. 6).

    Returns
    -------
    ndarray, shape (order, order)
        ``T[i, j] = (-1)^j binom(i, j) / dt_s^i``; lower triangular, invertible.
    """
    T = np.zeros((order, order))
    for i in range(order):
        for j in range(i + 1):
            T[i, j] = (-1) ** j * comb(i, j) / dt_s**i
    return T


def difference_states(y: np.ndarray, order: int, dt_s: float) -> np.ndarray:
    """States of eq. (6) from a force sequence, with ``y(k) = 0`` before the start.

    Parameters
    ----------
    y : ndarray, shape (n_samples,)
        Force (normalized or in N).
    order : int
        Model order ``n``.
    dt_s : float
        Sample time Ts in seconds.

    Returns
    -------
    ndarray, shape (n_samples, order)
        Rows ``k >= order - 1`` use measured samples only.
    """
    y = np.asarray(y, dtype=np.float64)
    padded = np.concatenate([np.zeros(order - 1), y])
    # lags[k, j] = y(k - j)
    lags = np.lib.stride_tricks.sliding_window_view(padded, order)[:, ::-1]
    return lags @ difference_transform(order, dt_s).T


@dataclass(frozen=True)
class RLSResult:
    """Outcome of :func:`rls`.

    Attributes
    ----------
    theta : ndarray, shape (n_regressors, n_outputs)
        Final parameter matrix.
    P : ndarray, shape (n_regressors, n_regressors)
        Final covariance (symmetric).
    prior_errors : ndarray, shape (n_rows, n_outputs)
        ``e(k) = Y(k) - phi(k)^T theta(k-1)`` (eq. 9).
    residuals : ndarray, shape (n_rows, n_outputs)
        A posteriori residuals ``w(k) = Y(k) - phi(k)^T theta(k)`` (eq. 14).
    """

    theta: np.ndarray
    P: np.ndarray
    prior_errors: np.ndarray
    residuals: np.ndarray


def rls(
    Phi: np.ndarray,
    Y: np.ndarray,
    *,
    noise_regressor: bool = True,
    forgetting: float = 1.0,
    theta0: float = 0.3,
    p0: float = 1000.0,
) -> RLSResult:
    """Multi-output RLS with an optional pseudo-linear noise regressor (eqs. 11-16).

    Parameters
    ----------
    Phi : ndarray, shape (n_rows, n_fixed)
        Measured part of the regressor per row (``[x(k-1); u(k-1)]``).
    Y : ndarray, shape (n_rows, n_outputs)
        Targets per row (``x(k)``).
    noise_regressor : bool
        Append ``w(k-1)`` (the previous row's a posteriori residual, length
        ``n_outputs``) to each regressor, as the paper does.
    forgetting : float
        Forgetting factor lambda in (0, 1]; 1 is the paper's plain RLS.
    theta0 : float
        Initial value of every parameter (paper: 0.3).
    p0 : float
        Initial covariance ``P(0) = p0 I`` (paper: about 1e3).

    Returns
    -------
    RLSResult

    Notes
    -----
    Per row: ``K = P phi / (lambda + phi^T P phi)``, ``theta += K e^T``,
    ``P = (P - K phi^T P) / lambda``. ``P`` is kept exactly symmetric: only its
    upper triangle is stored and updated (BLAS ``dsymv``/``dsyr``), which is the
    paper's update followed by ``P = (P + P^T) / 2`` without the rounding drift.
    The a posteriori residual is ``w = e lambda / (lambda + phi^T P phi)``.
    """
    Phi = np.asarray(Phi, dtype=np.float64)
    Y = np.asarray(Y, dtype=np.float64)
    if Phi.ndim != 2 or Y.ndim != 2 or Phi.shape[0] != Y.shape[0]:
        raise EstimationInputError(
            f"Phi (n_rows, n_fixed) and Y (n_rows, n_outputs) must share rows, "
            f"found {Phi.shape} and {Y.shape}"
        )
    if not 0.0 < forgetting <= 1.0:
        raise EstimationInputError(f"forgetting must be in (0, 1], found {forgetting!r}")
    if not p0 > 0:
        raise EstimationInputError(f"p0 must be positive, found {p0!r}")
    n_rows, n_fixed = Phi.shape
    n_out = Y.shape[1]
    n_reg = n_fixed + (n_out if noise_regressor else 0)
    theta = np.full((n_reg, n_out), float(theta0), order="F")
    P = np.asfortranarray(np.eye(n_reg) * float(p0))  # upper triangle is authoritative
    # regressor rows [x(k-1), u(k-1), w(k-1)]; w of row k is written into row k + 1
    reg = np.zeros((n_rows + 1, n_reg))
    reg[:n_rows, :n_fixed] = Phi
    w_next = reg[1:, n_fixed:]
    prior = np.empty((n_rows, n_out))
    denoms: list[float] = []
    lam = float(forgetting)
    inv_lam = 1.0 / lam
    # The loop is all call overhead (117 rows of 17 regressors for the paper's
    # model): the f2py BLAS wrappers take their arguments positionally (keyword
    # parsing cost three times the arithmetic) and the dots are ndarray methods.
    # Same BLAS routines, same operands, hence the same floats as before.
    subtract, multiply = np.subtract, np.multiply
    # Row views come from iterating the arrays (cheaper than indexing), and the
    # scalars are Python floats (cheaper than numpy scalars, the same values).
    rows = zip(reg[:n_rows], Y, prior, w_next, strict=True)
    for phi, y_k, e, w_k in rows:
        Pphi = dsymv(1.0, P, phi)
        denom = lam + float(phi.dot(Pphi))
        subtract(y_k, phi.dot(theta), e)
        # theta += Pphi e^T / denom   (dger: alpha, x, y, incx, incy, a, overwrite x, y, a)
        dger(1.0 / denom, Pphi, e, 1, 1, theta, 1, 1, 1)
        if noise_regressor:
            multiply(e, lam / denom, w_k)
        # P -= Pphi Pphi^T / denom on the upper triangle (dsyr: alpha, x, lower, incx,
        # offx, n, a, overwrite_a)
        dsyr(-1.0 / denom, Pphi, 0, 1, 0, n_reg, P, 1)
        if lam != 1.0:
            P *= inv_lam
        denoms.append(denom)
    P_full = np.triu(P) + np.triu(P, 1).T
    post = prior * (lam / np.array(denoms))[:, None]
    return RLSResult(theta=np.ascontiguousarray(theta), P=P_full, prior_errors=prior,
                     residuals=post)
