"""The paper's state-space force model, with (SS_KF) and without (SS) Kalman filter.

scikit-learn style::

    est = SSEstimator(order=4, kalman=True).fit(U, y)    # normalized features / force
    est.model_                 # control.StateSpace(A_, B_, C_, 0, dt=0.125)
    est.predict(U, y, mode="one_step")                   # paper's evaluation
    est.predict(U, mode="free_run")                      # sEMG only (deployable)
    stream = est.streaming(mode="one_step"); stream.step(u, y_prev)

Modes (``yhat(k)`` always uses inputs up to ``k - 1``, the model's structure, eq. 4):

- ``one_step`` with ``kalman=True``: the paper's estimator (eq. 16)
  ``xhat(k) = (A - L C) xhat(k-1) + B u(k-1) + L y(k-1)`` with the predictor gain L.
- ``one_step`` with ``kalman=False``: ``yhat(k) = C (A x(k-1) + B u(k-1))`` with
  ``x(k-1)`` built from the measured force (eq. 6), i.e. the plain SS model.
- ``free_run``: ``xhat(k) = A xhat(k-1) + B u(k-1)``: no force is measured. Refused
  with :class:`~estimation.errors.UnstableModelError` when ``A`` has a pole on or outside the
  unit circle.

All predictions start from a zero state (force at rest).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from sklearn.exceptions import NotFittedError

from estimation.base import ForceEstimator
from estimation.errors import (
    InsufficientDataError,
    UnstableModelError,
    check_features,
    check_mode,
    check_not_constant,
    check_target,
    require_force,
)
from estimation.kalman import design_kalman, process_noise_covariance
from estimation.normalize import MinMaxScaling
from estimation.rls import difference_states, difference_transform, rls
from estimation.streaming import DelayedLTIStream, delayed_response, delayed_response_affine

if TYPE_CHECKING:
    import control

#: Paper sample time: 125 ms window increment.
PAPER_DT_S = 0.125


def identification_rows(
    U: np.ndarray, y: np.ndarray, order: int, dt_s: float
) -> tuple[np.ndarray, np.ndarray]:
    """Regression rows of eq. (10) using measured samples only.

    Returns
    -------
    Phi : ndarray, shape (n_samples - order, order + n_inputs)
        ``[x(k-1), u(k-1)]`` for ``k = order .. n_samples - 1``.
    X : ndarray, shape (n_samples - order, order)
        Targets ``x(k)``.
    """
    states = difference_states(y, order, dt_s)
    Phi = np.hstack([states[order - 1:-1], U[order - 1:-1]])
    return Phi, states[order:]


def _ctrb(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Controllability matrix ``[B, A B, ..., A^(n-1) B]``, shape (n, n * m).

    What ``control.ctrb`` builds, without its input conversion (which cost
    more than the products here); the observability matrix is
    ``_ctrb(A.T, C.T).T``, which has the same rank.
    """
    n, m = B.shape
    out = np.empty((n, n * m))
    out[:, :m] = B
    for k in range(1, n):
        out[:, k * m:(k + 1) * m] = A.dot(out[:, (k - 1) * m:k * m])
    return out


class SSEstimator(ForceEstimator):
    """RLS-identified state-space model of grip force, optionally with a Kalman filter.

    Parameters
    ----------
    order : int
        Model order n (paper: 4, chosen by AIC).
    kalman : bool
        Predict through the steady-state Kalman predictor (SS_KF) in ``one_step``
        mode; otherwise use measured states (SS).
    forgetting : float
        RLS forgetting factor in (0, 1] (paper: 1).
    theta0, p0 : float
        RLS initialization ``theta(0) = theta0``, ``P(0) = p0 I`` (paper: 0.3, 1e3).
    dt_s : float
        Sample time Ts in seconds (paper: 0.125 s).
    noise_regressor : bool
        Include ``w(k-1)`` in the regressor (paper: yes). Without it, ``Gamma_ = I``.
    kalman_method : {"doubling", "scipy", "control"}
        Riccati solver, see :func:`estimation.kalman.design_kalman`.

    Attributes
    ----------
    A_ : ndarray, shape (n, n)
    B_ : ndarray, shape (n, n_inputs)
    Gamma_ : ndarray, shape (n, n)
    C_ : ndarray, shape (1, n)
        ``[1, 0, ..., 0]`` (eq. 8).
    sigma_w2_ : ndarray, shape (n,)
        Process-noise variances of the RLS a posteriori residuals ``w`` (eq. 14).
    sigma_v2_ : float
        Measurement-noise variance of ``v = y - C xhat`` (eq. 15).
    Q_, R_ : ndarray
        ``Gamma diag(sigma_w^2) Gamma^T`` (n, n) and ``[[sigma_v^2]]`` (1, 1).
    model_ : control.StateSpace
        ``(A_, B_, C_, 0)`` with ``dt = dt_s``, built from the fitted matrices on
        access (``control.StateSpace`` does not pickle; the estimator does).
    poles_ : ndarray, shape (n,)
    stable_, controllable_, observable_ : bool
        Paper Table 3 columns.
    predictor_gain_, filter_gain_ : ndarray, shape (n, 1)
        Kalman gains (only when ``kalman=True``); ``kalman_poles_`` = eig(A - L C).
    n_features_in_ : int
    """

    modes = ("one_step", "free_run")

    def __init__(
        self,
        *,
        order: int = 4,
        kalman: bool = True,
        forgetting: float = 1.0,
        theta0: float = 0.3,
        p0: float = 1000.0,
        dt_s: float = PAPER_DT_S,
        noise_regressor: bool = True,
        kalman_method: str = "doubling",
    ) -> None:
        self.order = order
        self.kalman = kalman
        self.forgetting = forgetting
        self.theta0 = theta0
        self.p0 = p0
        self.dt_s = dt_s
        self.noise_regressor = noise_regressor
        self.kalman_method = kalman_method

    # ------------------------------------------------------------------ fit
    def fit(self, U: np.ndarray, y: np.ndarray) -> SSEstimator:
        """Identify ``A, B, Gamma`` by RLS and, if ``kalman``, design the filter.

        Parameters
        ----------
        U : ndarray, shape (n_samples, n_inputs)
            Normalized features ``u(k)``.
        y : ndarray, shape (n_samples,)
            Normalized measured force.

        Raises
        ------
        EstimationInputError, ConstantInputError, InsufficientDataError, RiccatiError
        """
        U = check_features(U)
        y = check_target(y, U.shape[0])
        n = int(self.order)
        if n < 1:
            raise InsufficientDataError(f"order must be >= 1, found {self.order!r}")
        n_inputs = U.shape[1]
        n_reg = 2 * n + n_inputs if self.noise_regressor else n + n_inputs
        n_rows = U.shape[0] - n
        if n_rows < n_reg + 2:
            raise InsufficientDataError(
                f"order {n} with {n_inputs} inputs needs at least {n + n_reg + 2} samples "
                f"({n_reg} parameters per state plus burn-in), "
                f"found n_samples = {U.shape[0]} (n_features = {n_inputs})"
            )
        check_not_constant(U, y)
        Phi, X = identification_rows(U, y, n, self.dt_s)
        res = rls(Phi, X, noise_regressor=self.noise_regressor, forgetting=self.forgetting,
                  theta0=self.theta0, p0=self.p0)
        theta = res.theta
        self.theta_ = theta
        self.A_ = theta[:n].T.copy()
        self.B_ = theta[n:n + n_inputs].T.copy()
        self.Gamma_ = theta[n + n_inputs:].T.copy() if self.noise_regressor else np.eye(n)
        self.C_ = np.eye(1, n)
        # Noise statistics after the first n_reg rows (the transient before the
        # regression is determined); eqs. (14) and (15).
        self.sigma_w2_ = np.var(res.residuals[n_reg:], axis=0)
        self.sigma_v2_ = float(np.var(res.prior_errors[n_reg:, 0]))
        self.Q_ = process_noise_covariance(self.Gamma_, self.sigma_w2_)
        self.R_ = np.array([[self.sigma_v2_]])
        self.poles_ = np.linalg.eigvals(self.A_)
        self.stable_ = bool(np.max(np.abs(self.poles_)) < 1.0)
        self.n_features_in_ = n_inputs
        self.order_ = n
        self.rls_ = res
        if self.kalman:
            kf = design_kalman(self.A_, self.C_, self.Q_, self.R_, method=self.kalman_method)
            self.predictor_gain_ = kf.predictor_gain
            self.filter_gain_ = kf.filter_gain
            self.kalman_P_ = kf.P
            self.kalman_poles_ = kf.poles
        self._lti_cache: dict[str, tuple[np.ndarray, ...]] = {}
        return self

    @property
    def controllable_(self) -> bool:
        """``(A_, B_)`` controllable (rank test; computed when read, not in :meth:`fit`)."""
        self._check_fitted()
        return bool(np.linalg.matrix_rank(_ctrb(self.A_, self.B_)) == self.order_)

    @property
    def observable_(self) -> bool:
        """``(A_, C_)`` observable (rank test; computed when read, not in :meth:`fit`)."""
        self._check_fitted()
        return bool(np.linalg.matrix_rank(_ctrb(self.A_.T, self.C_.T)) == self.order_)

    @property
    def model_(self) -> control.StateSpace:
        """``control.StateSpace(A_, B_, C_, 0, dt_s)`` of the fitted model."""
        import control
        self._check_fitted()
        return control.ss(self.A_, self.B_, self.C_, np.zeros((1, self.n_features_in_)),
                          self.dt_s)

    # -------------------------------------------------------------- predict
    def _check_fitted(self) -> None:
        if not hasattr(self, "A_"):
            raise NotFittedError("SSEstimator is not fitted; call fit(U, y) first")

    def lti(self, mode: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray]:
        """``(F, Gu, Gy, h)`` of the predictor used in ``mode`` (see :mod:`.streaming`).

        Raises
        ------
        ModeError
            Unknown mode.
        UnstableModelError
            ``free_run`` with an unstable ``A``.
        """
        self._check_fitted()
        check_mode(mode, self.modes, type(self).__name__)
        if mode in self._lti_cache:
            return self._lti_cache[mode]
        n = self.order_
        h = self.C_[0]
        if mode == "free_run":
            if not self.stable_:
                raise UnstableModelError(
                    f"identified A is unstable (max |pole| = {np.max(np.abs(self.poles_)):.6g}, "
                    "expected < 1); refusing to run it open loop"
                )
            out = (self.A_, self.B_, None, h)
        elif self.kalman:
            L = self.predictor_gain_
            out = (self.A_ - L @ self.C_, self.B_, L[:, 0], h)
        else:
            # state s(k) = [y(k-1), ..., y(k-n), C B u(k-1)]
            F = np.zeros((n + 1, n + 1))
            F[1:n, 0:n - 1] = np.eye(n - 1)
            Gu = np.zeros((n + 1, self.n_features_in_))
            Gu[n] = (self.C_ @ self.B_)[0]
            Gy = np.zeros(n + 1)
            Gy[0] = 1.0
            hh = np.concatenate([(self.C_ @ self.A_ @ difference_transform(n, self.dt_s))[0],
                                 [1.0]])
            out = (F, Gu, Gy, hh)
        self._lti_cache[mode] = out
        return out

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate ``yhat(k)`` for every row of ``U``, shape (n_samples,).

        Parameters
        ----------
        U : ndarray, shape (n_samples, n_inputs)
            Normalized features.
        y : ndarray, shape (n_samples,), optional
            Normalized measured force; required for ``one_step`` (only
            ``y[:k]`` enters ``yhat[k]``), ignored in ``free_run``.
        mode : {"one_step", "free_run"}, optional
            Default: ``one_step`` when ``y`` is given, else ``free_run``.
        """
        mode = self._mode(mode, y)
        F, Gu, Gy, h = self.lti(mode)
        U = check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__)
        if Gy is None:
            return delayed_response(F, Gu, h, U)
        y = check_target(require_force(y, mode, type(self).__name__), U.shape[0])
        return delayed_response(F, np.hstack([Gu, Gy[:, None]]), h, np.hstack([U, y[:, None]]))

    def predict_scaled(self, U: np.ndarray, y: np.ndarray | None, *, mode: str,
                       scaling: MinMaxScaling) -> np.ndarray:
        """Force estimate in N from raw features, the scaling folded into the filter.

        What :class:`~estimation.pipeline.ForcePipeline` calls instead of
        normalizing ``U``: equal to ``scaling.inverse_y(predict(scaling.transform_u(U),
        scaling.transform_y(y), mode=mode))`` to rounding (see
        :func:`~estimation.streaming.delayed_response_affine`).

        Parameters
        ----------
        U : ndarray, shape (n_samples, n_inputs)
            Raw features, already validated (finite, float64, ``n_features_in_`` columns).
        y : ndarray, shape (n_samples,) or None
            Measured force in N, validated; required for ``one_step``.
        mode : {"one_step", "free_run"}
        scaling : MinMaxScaling

        Returns
        -------
        ndarray, shape (n_samples,)
        """
        cls = type(self)
        if cls.predict is not SSEstimator.predict or cls.lti is not SSEstimator.lti:
            # a subclass with its own prediction (e.g. SimulationErrorSS): normalize
            y_n = None if y is None else scaling.transform_y(y)
            return scaling.inverse_y(self.predict(scaling.transform_u(U), y_n, mode=mode))
        F, Gu, Gy, h = self.lti(mode)
        if Gy is not None:
            y = require_force(y, mode, type(self).__name__)
        return delayed_response_affine(F, Gu, Gy, h, U, y, scaling=scaling)

    def streaming(self, mode: str = "one_step", *,
                  scaling: MinMaxScaling | None = None) -> DelayedLTIStream:
        """A :class:`~estimation.streaming.DelayedLTIStream` for real-time use in ``mode``."""
        F, Gu, Gy, h = self.lti(mode)
        return DelayedLTIStream(F, Gu, Gy, h, mode=mode, scaling=scaling)

