"""Model-order selection with the paper's AIC (eq. 19).

``AIC(n) = (1 + 2 p / N) * sum_k (y(k) - yhat(k))^2`` -- N times the first-order
approximation of Akaike's final prediction error. ``yhat(k) = C phi(k)^T theta``
is the identified model's one-step output with the final parameters, ``p`` the
number of parameters it depends on (the first column of ``theta``:
``2n + i`` with the noise regressor, ``n + i`` without), and the sum runs over
the same samples ``k >= max(orders)`` for every order so that ``N`` is common.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from estimation.errors import InsufficientDataError, check_features, check_target
from estimation.state_space import PAPER_DT_S, SSEstimator, identification_rows


@dataclass(frozen=True)
class OrderSelection:
    """AIC curve over candidate orders.

    Attributes
    ----------
    orders : ndarray of int, shape (n_orders,)
    aic : ndarray, shape (n_orders,)
        Paper AIC in squared (normalized) force units.
    sse : ndarray, shape (n_orders,)
        Sum of squared one-step output errors.
    n_params : ndarray of int, shape (n_orders,)
        ``p`` per order.
    n_obs : int
        ``N``, the common number of scored samples.
    order : int
        Order with the smallest AIC.
    """

    orders: np.ndarray
    aic: np.ndarray
    sse: np.ndarray
    n_params: np.ndarray
    n_obs: int
    order: int


def one_step_output_errors(est: SSEstimator, U: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``y(k) - C phi(k)^T theta`` for ``k = order .. n_samples - 1``, shape (n_samples - order,).

    ``phi(k)`` includes the RLS residual ``w(k-1)`` when the model has the noise regressor.
    """
    n = est.order_
    Phi, X = identification_rows(U, y, n, est.dt_s)
    if est.noise_regressor:
        w_prev = np.vstack([np.zeros((1, n)), est.rls_.residuals[:-1]])
        Phi = np.hstack([Phi, w_prev])
    return X[:, 0] - Phi @ est.theta_[:, 0]


def select_order(
    U: np.ndarray,
    y: np.ndarray,
    *,
    orders: Iterable[int] = range(1, 13),
    dt_s: float = PAPER_DT_S,
    **ss_params: object,
) -> OrderSelection:
    """Identify one model per order and score it with the paper's AIC.

    Parameters
    ----------
    U : ndarray, shape (n_samples, n_inputs)
        Normalized identification features.
    y : ndarray, shape (n_samples,)
        Normalized identification force.
    orders : iterable of int
        Candidates (paper: 1..12).
    dt_s : float
        Sample time in seconds.
    **ss_params
        Further :class:`~estimation.state_space.SSEstimator` hyperparameters (``forgetting``,
        ``p0``...).

    Raises
    ------
    InsufficientDataError
        Too few samples for the largest order.
    """
    U = check_features(U)
    y = check_target(y, U.shape[0])
    orders_arr = np.array(sorted(set(int(n) for n in orders)))
    if orders_arr.size == 0 or orders_arr[0] < 1:
        raise InsufficientDataError(f"orders must be >= 1, found {orders_arr.tolist()}")
    n_max = int(orders_arr[-1])
    aic, sse, n_params = [], [], []
    for n in orders_arr:
        est = SSEstimator(order=int(n), kalman=False, dt_s=dt_s, **ss_params).fit(U, y)
        err = one_step_output_errors(est, U, y)[n_max - n:]
        p = (2 * n if est.noise_regressor else n) + U.shape[1]
        s = float(err @ err)
        n_obs = err.size
        sse.append(s)
        n_params.append(p)
        aic.append((1.0 + 2.0 * p / n_obs) * s)
    aic_arr = np.array(aic)
    return OrderSelection(orders=orders_arr, aic=aic_arr, sse=np.array(sse),
                          n_params=np.array(n_params), n_obs=int(n_obs),
                          order=int(orders_arr[int(np.argmin(aic_arr))]))
