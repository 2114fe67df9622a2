"""Deployable force estimators: sEMG only, trained with a validation split, streamable.

Both work in normalized units (features and force min-max scaled 0..1 on the
identification data by :class:`~estimation.pipeline.ForcePipeline`) and never use
the measured force at run time, so ``one_step`` and ``free_run`` coincide (both
modes are listed, like the other static estimators).

Regressors at window ``k`` (``L`` past windows; the first window is repeated
before the start of the record, in batch and in the stream alike)::

    r(k) = [v(k), v(k-1), ..., v(k-L)],
    v = sqrt(max(u, 0))                       (compress="sqrt", default)
    v = [u, log(floor + max(u, 0))]           (compress="log")

``LogRidge`` ("ridge")
    Ridge regression on standardized ``r``; the penalty and ``L`` are chosen on a
    contiguous validation split (the last ``validation_fraction`` of the
    identification data), then refitted on all of it. Compressed features of
    every channel give a concave sEMG-force shape that still extrapolates to
    forces above the identification range (the paper's split puts the strongest
    squeeze in the validation half) and damp the sEMG amplitude fluctuations
    that force does not share; on the default virtual populations the square
    root did better than log + linear (both are available).
``BoostedLogRidge`` ("gbt")
    The same ridge plus scikit-learn's ``HistGradientBoostingRegressor`` on its
    residuals (shallow trees, so the linear part still carries extrapolation);
    the number of trees is chosen on the same validation split (0 trees allowed).

Both end with a first-order output smoother ``s(k) = a s(k-1) + (1 - a) yhat(k)``
whose ``a`` is chosen on the validation split (``a = 0`` is no smoothing).
"""

from __future__ import annotations

import numpy as np
from sklearn.ensemble import HistGradientBoostingRegressor

from estimation.base import ForceEstimator
from estimation.errors import EstimationInputError, check_features, check_mode, check_target
from estimation.normalize import MinMaxScaling
from sim.errors import GriploopError


class StreamingRateError(GriploopError, ValueError):
    """A stream asked to run faster than the window increment its lags were trained on."""


def check_period(period_s: float | None, dt_s: float, who: str) -> None:
    """Raise :class:`StreamingRateError` if ``period_s`` is shorter than ``dt_s``.

    Parameters
    ----------
    period_s : float or None
        Interval between ``step`` calls in seconds (``None``: not checked).
    dt_s : float
        Window increment the estimator was trained on, seconds.
    who : str
        Estimator name for the message.
    """
    if period_s is not None and float(period_s) < dt_s * (1.0 - 1e-9):
        raise StreamingRateError(
            f"{who} was trained on a new window every {dt_s:.4g} s; expected one step per "
            f"window (period >= {dt_s:.4g} s), found a period of {float(period_s):.4g} s"
        )


COMPRESSIONS = ("sqrt", "log")


def compressed(U: np.ndarray, compress: str, floor: float) -> np.ndarray:
    """``sqrt(max(u, 0))`` or ``[u, log(floor + max(u, 0))]``, row by row."""
    if compress == "sqrt":
        return np.sqrt(np.maximum(U, 0.0))
    if compress == "log":
        return np.hstack([U, np.log(floor + np.maximum(U, 0.0))])
    raise EstimationInputError(f"compress: expected one of {COMPRESSIONS}, found {compress!r}")


def log_lag_regressors(U: np.ndarray, lags: int, floor: float,
                       compress: str = "log") -> np.ndarray:
    """``[v(k), ..., v(k - lags)]`` with ``v`` the compressed features of window ``k``.

    Parameters
    ----------
    U : ndarray, shape (n_samples, n_inputs)
        Normalized features.
    lags : int
        Past windows appended.
    floor : float
        Offset inside the logarithm (normalized units).
    compress : {"sqrt", "log"}
        ``sqrt(max(u, 0))`` or ``[u, log(floor + max(u, 0))]``.

    Returns
    -------
    ndarray, shape (n_samples, n_v (lags + 1))
    """
    V = compressed(U, compress, floor)
    n = V.shape[0]
    P = np.vstack([np.repeat(V[:1], lags, axis=0), V])
    return np.hstack([P[lags - j: lags - j + n] for j in range(lags + 1)])


def _ridge(Z: np.ndarray, y: np.ndarray, alpha: float) -> tuple[np.ndarray, float]:
    """Ridge weights and intercept on (already standardized) columns ``Z``."""
    zm, ym = Z.mean(axis=0), y.mean()
    Zc = Z - zm
    w = np.linalg.solve(Zc.T @ Zc + alpha * np.eye(Z.shape[1]), Zc.T @ (y - ym))
    return w, float(ym - zm @ w)


def smooth(y: np.ndarray, a: float) -> np.ndarray:
    """``s(k) = a s(k-1) + (1 - a) y(k)``, ``s(0) = y(0)``."""
    if a == 0.0:
        return np.asarray(y, dtype=float).copy()
    out = np.empty(len(y))
    s = float(y[0])
    for k, v in enumerate(y):
        s = a * s + (1.0 - a) * v
        out[k] = s
    return out


def _mse(y: np.ndarray, yhat: np.ndarray) -> float:
    return float(np.mean((y - yhat) ** 2))


class LogRidge(ForceEstimator):
    """Ridge regression on log and linear features of every channel with past windows.

    Parameters
    ----------
    lags : tuple of int
        Candidate numbers of past windows in the regressor (chosen on validation).
    compress : {"sqrt", "log"}
        Feature compression (see the module docstring).
    alphas : tuple of float
        Candidate ridge penalties (on standardized regressors).
    smoothers : tuple of float
        Candidate output-smoother poles ``a`` (0 = none).
    floor : float
        Offset inside the logarithm, normalized units.
    validation_fraction : float
        Last fraction of the identification data used to choose ``alpha``, ``a``
        (and the number of trees); never the training loss.
    dt_s : float
        Window increment in seconds (the lags' spacing); streams refuse a shorter period.

    Attributes
    ----------
    alpha_, smoother_ : float
        Chosen penalty and smoother pole.
    lags_ : int
        Chosen number of past windows.
    coef_ : ndarray, shape (n_regressors,)
        Weights on raw (unstandardized) regressors; ``intercept_`` the offset.
    validation_mse_ : float
        Validation-split MSE of the chosen settings (normalized units).
    """

    modes = ("one_step", "free_run")  # the force is never used: both modes coincide
    name = "LogRidge"

    def __init__(self, *, lags: tuple[int, ...] = (0, 1), compress: str = "sqrt",
                 alphas: tuple[float, ...] = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0),
                 smoothers: tuple[float, ...] = (0.0, 0.2, 0.4, 0.6), floor: float = 0.02,
                 validation_fraction: float = 0.3, dt_s: float = 0.125) -> None:
        self.lags = lags
        self.compress = compress
        self.alphas = alphas
        self.smoothers = smoothers
        self.floor = floor
        self.validation_fraction = validation_fraction
        self.dt_s = dt_s

    # ------------------------------------------------------------------ fit
    def _linear(self, R: np.ndarray, y: np.ndarray, alpha: float) -> tuple[np.ndarray, float]:
        mu, sd = R.mean(axis=0), R.std(axis=0)
        sd[sd == 0] = 1.0
        w, b = _ridge((R - mu) / sd, y, alpha)
        coef = w / sd
        return coef, b - float(mu @ coef)

    def _split(self, n: int, n_features: int) -> int:
        n_tr = int(round((1.0 - self.validation_fraction) * n))
        if n_tr < 4 or n - n_tr < 2:
            raise EstimationInputError(
                f"{self.name}: {n} identification windows leave {n_tr}/{n - n_tr} for "
                "training/validation; expected at least 4 and 2 "
                f"(found n_samples = {n}, n_features = {n_features})"
            )
        return n_tr

    def _fit_residual(self, R: np.ndarray, res: np.ndarray, n_tr: int) -> tuple[np.ndarray, int]:
        """Validation-split prediction of a residual model and its size (none here)."""
        return np.zeros(R.shape[0] - n_tr), 0

    def _refit_residual(self, R: np.ndarray, res: np.ndarray, size: int) -> None:
        """Refit the residual model on all identification data (none here)."""

    def _residual(self, R: np.ndarray) -> np.ndarray:
        return np.zeros(R.shape[0])

    def fit(self, U: np.ndarray, y: np.ndarray) -> LogRidge:
        """Fit on normalized features ``U`` (n_samples, n_inputs) and force ``y``."""
        U = check_features(U)
        y = check_target(y, U.shape[0])
        if self.compress not in COMPRESSIONS:
            raise EstimationInputError(
                f"compress: expected one of {COMPRESSIONS}, found {self.compress!r}")
        lag_set = (self.lags,) if isinstance(self.lags, (int, np.integer)) else tuple(self.lags)
        if not lag_set or min(lag_set) < 0:
            raise EstimationInputError(f"lags: expected non-negative counts, found {self.lags!r}")
        n_tr = self._split(U.shape[0], U.shape[1])
        best = None
        for lags in lag_set:
            Rl = log_lag_regressors(U, int(lags), self.floor, self.compress)
            for alpha in self.alphas:
                coef, b = self._linear(Rl[:n_tr], y[:n_tr], alpha)
                lin = Rl @ coef + b
                err = _mse(y[n_tr:], lin[n_tr:])
                if best is None or err < best[0]:
                    best = (err, alpha, int(lags), lin)
        _, self.alpha_, self.lags_, lin = best
        R = log_lag_regressors(U, self.lags_, self.floor, self.compress)
        res_val, size = self._fit_residual(R, y - lin, n_tr)
        raw = lin.copy()
        raw[n_tr:] += res_val
        scores = [(_mse(y[n_tr:], smooth(raw, a)[n_tr:]), a) for a in self.smoothers]
        self.validation_mse_, self.smoother_ = min(scores)
        self.coef_, self.intercept_ = self._linear(R, y, self.alpha_)
        self._refit_residual(R, y - (R @ self.coef_ + self.intercept_), size)
        self.n_features_in_ = U.shape[1]
        return self

    # -------------------------------------------------------------- predict
    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate, shape (n_samples,); ``y`` is ignored (sEMG only)."""
        self._mode(mode, y)
        U = check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__)
        R = log_lag_regressors(U, self.lags_, self.floor, self.compress)
        return smooth(R @ self.coef_ + self.intercept_ + self._residual(R), self.smoother_)

    def streaming(self, mode: str = "free_run", *, scaling: MinMaxScaling | None = None,
                  period_s: float | None = None) -> object:
        """A stream equal to :meth:`predict`; ``period_s`` (s) shorter than ``dt_s`` is refused."""
        check_mode(mode, self.modes, self.name)
        check_period(period_s, self.dt_s, self.name)
        return _LogLagStream(self, mode, scaling)

    def _tree_tables(self) -> list:
        return []


class BoostedLogRidge(LogRidge):
    """:class:`LogRidge` plus gradient-boosted trees on its residuals.

    Parameters
    ----------
    max_trees : int
        Upper limit of boosting iterations; the count used is chosen on the
        validation split.
    max_depth, learning_rate, min_samples_leaf, l2_regularization :
        ``HistGradientBoostingRegressor`` settings.
    random_state : numpy.random.Generator, int or None
        Seeds scikit-learn (the trees are deterministic without subsampling).
    lags, compress, alphas, smoothers, floor, validation_fraction, dt_s
        As :class:`LogRidge`.

    Attributes
    ----------
    n_trees_ : int
        Trees kept (0 when boosting did not help on the validation split).
    """

    name = "BoostedLogRidge"

    def __init__(self, *, max_trees: int = 60, max_depth: int = 3, learning_rate: float = 0.1,
                 min_samples_leaf: int = 10, l2_regularization: float = 1.0,
                 random_state: np.random.Generator | int | None = None,
                 lags: tuple[int, ...] = (0, 1), compress: str = "sqrt",
                 alphas: tuple[float, ...] = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0),
                 smoothers: tuple[float, ...] = (0.0, 0.2, 0.4, 0.6), floor: float = 0.02,
                 validation_fraction: float = 0.3, dt_s: float = 0.125) -> None:
        # explicit (no **kwargs): scikit-learn's get_params reads the signature
        super().__init__(lags=lags, compress=compress, alphas=alphas, smoothers=smoothers,
                         floor=floor, validation_fraction=validation_fraction, dt_s=dt_s)
        self.max_trees = max_trees
        self.max_depth = max_depth
        self.learning_rate = learning_rate
        self.min_samples_leaf = min_samples_leaf
        self.l2_regularization = l2_regularization
        self.random_state = random_state

    def _hgb(self, n_trees: int) -> HistGradientBoostingRegressor:
        seed = int(np.random.default_rng(self.random_state).integers(0, 2**31 - 1)) \
            if not isinstance(self.random_state, int) else self.random_state
        return HistGradientBoostingRegressor(
            max_iter=n_trees, max_depth=self.max_depth, learning_rate=self.learning_rate,
            min_samples_leaf=self.min_samples_leaf, l2_regularization=self.l2_regularization,
            early_stopping=False, random_state=seed)

    def _fit_residual(self, R: np.ndarray, res: np.ndarray, n_tr: int) -> tuple[np.ndarray, int]:
        hgb = self._hgb(self.max_trees).fit(R[:n_tr], res[:n_tr])
        best_err, best_k, best_pred = _mse(res[n_tr:], 0.0), 0, np.zeros(R.shape[0] - n_tr)
        for k, pred in enumerate(hgb.staged_predict(R[n_tr:]), start=1):
            err = _mse(res[n_tr:], pred)
            if err < best_err:
                best_err, best_k, best_pred = err, k, pred
        return best_pred, best_k

    def _refit_residual(self, R: np.ndarray, res: np.ndarray, size: int) -> None:
        self.n_trees_ = int(size)
        self.hgb_ = self._hgb(size).fit(R, res) if size > 0 else None

    def _residual(self, R: np.ndarray) -> np.ndarray:
        return np.zeros(R.shape[0]) if self.hgb_ is None else self.hgb_.predict(R)

    def _tree_tables(self) -> list:
        """Per tree ``(feature, threshold, left, right, value, is_leaf)`` lists, plus baseline."""
        if self.hgb_ is None:
            return []
        tables = []
        for (pred,) in self.hgb_._predictors:
            nodes = pred.nodes
            tables.append((nodes["feature_idx"].tolist(), nodes["num_threshold"].tolist(),
                           nodes["left"].tolist(), nodes["right"].tolist(),
                           nodes["value"].tolist(), nodes["is_leaf"].astype(bool).tolist()))
        return tables


class _LogLagStream:
    """Per-window stream of :class:`LogRidge` / :class:`BoostedLogRidge` (normalized units)."""

    uses_force = False

    def __init__(self, est: LogRidge, mode: str, scaling: MinMaxScaling | None = None) -> None:
        self.mode = mode
        # scaling done exactly as MinMaxScaling.transform_u (trees compare thresholds)
        m0 = est.n_features_in_
        self._sqrt = est.compress == "sqrt"
        self._u_min = np.zeros(m0) if scaling is None else scaling.u_min.copy()
        self._u_span = np.ones(m0) if scaling is None else scaling.u_span.copy()
        self._y_min = 0.0 if scaling is None else float(scaling.y_min_n)
        self._y_span = 1.0 if scaling is None else float(scaling.y_span_n)
        self._u = np.empty(m0)
        m, L = est.n_features_in_, est.lags_
        self._m2 = m if est.compress == "sqrt" else 2 * m
        self._r = np.zeros(self._m2 * (L + 1))
        self._tmp = np.empty(self._m2 * L)
        self._coef = est.coef_.copy()
        self._b = float(est.intercept_)
        self._floor = float(est.floor)
        self._a = float(est.smoother_)
        self._L = L
        self._trees = est._tree_tables()
        hgb = getattr(est, "hgb_", None)
        self._base = float(hgb._baseline_prediction.ravel()[0]) if hgb is not None else 0.0
        self._first = True
        self._s = 0.0

    def reset(self) -> None:
        """Forget the history (the next window is repeated into the lags)."""
        self._r[:] = 0.0
        self._first = True
        self._s = 0.0

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Force estimate (N with scaling) for features ``u(k)``; ``y_prev`` is ignored."""
        r, m2 = self._r, self._m2
        np.subtract(u, self._u_min, out=self._u)
        np.divide(self._u, self._u_span, out=self._u)
        u = self._u
        if self._L:
            np.copyto(self._tmp, r[:-m2])
            np.copyto(r[m2:], self._tmp)
        now = r[:m2]
        if self._sqrt:
            np.maximum(u, 0.0, out=now)
            np.sqrt(now, out=now)
        else:
            m = m2 // 2
            now[:m] = u
            np.maximum(u, 0.0, out=now[m:])
            now[m:] += self._floor
            np.log(now[m:], out=now[m:])
        if self._first:
            for j in range(1, self._L + 1):
                r[j * m2:(j + 1) * m2] = now
        yhat = float(self._coef.dot(r)) + self._b
        if self._trees:
            x = r.tolist()
            acc = self._base
            for feat, thr, left, right, value, leaf in self._trees:
                node = 0
                while not leaf[node]:
                    node = left[node] if x[feat[node]] <= thr[node] else right[node]
                acc += value[node]
            yhat += acc
        if self._first:
            self._s = yhat
            self._first = False
        else:
            self._s = self._a * self._s + (1.0 - self._a) * yhat
        return self._s * self._y_span + self._y_min
