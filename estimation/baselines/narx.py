"""NARX network baseline (paper section 3.4.2): the MLP on delayed inputs and outputs.

Regressor at tick ``k`` (eq. 24), zero before the start of the record::

    r(k) = [u(k), u(k-1), ..., u(k-d), y(k-1), ..., y(k-d)]

with ``d`` the SS order (4). Trained series-parallel (measured ``y`` in the
regressor). ``one_step`` predicts with measured past force; ``free_run`` feeds
back its own past predictions (parallel / closed-loop NARX, sEMG only).

With ``linear_bypass`` (default) each mode gets the network trained for it:
``one_step`` outputs the measured ``y(k-1)`` plus an MLP that learns the change
``y(k) - y(k-1)`` from the same regressors (kept only if it beats zero change on
the last ``validation_fraction`` of the identification data), so one-step NARX
is not worse than persistence on held-out data; ``free_run`` uses the paper's
NARX network on the absolute force (``free_run_net_``), since fed-back
increments would integrate their errors. Both stop early on a validation split.
"""

from __future__ import annotations

import numpy as np

from estimation.baselines.mlp import MLPBaseline, MLPForward
from estimation.deployable import check_period
from estimation.errors import (
    ModeError,
    check_features,
    check_mode,
    check_target,
    require_force,
)
from estimation.normalize import MinMaxScaling
from estimation.streaming import scaled


def narx_regressors(U: np.ndarray, y: np.ndarray, delays: int) -> np.ndarray:
    """Series-parallel regressors, shape (n_samples, (delays + 1) n_inputs + delays)."""
    n, m = U.shape
    Up = np.vstack([np.zeros((delays, m)), U])
    yp = np.concatenate([np.zeros(delays), y])
    cols = [Up[delays - j: delays - j + n] for j in range(delays + 1)]
    cols += [yp[delays - j: delays - j + n, None] for j in range(1, delays + 1)]
    return np.hstack(cols)


class NARXBaseline(MLPBaseline):
    """Nonlinear ARX network: the paper's MLP on delayed inputs and outputs.

    Hyperparameters as :class:`~estimation.baselines.mlp.MLPBaseline`, plus ``delays`` (the SS
    order) and
    ``linear_bypass``; mini-batches of 4 by default (paper: 1) so that training both
    networks on all 8 channels (124 regressors) stays under 2 s.

    Attributes
    ----------
    net_ : MLPRegressor
    n_epochs_ : int
    converged_ : bool
    """

    modes = ("one_step", "free_run")

    def __init__(self, *, delays: int = 4, hidden: int = 4, max_epochs: int = 1000,
                 learning_rate: float = 1e-2, rho: float = 0.9, tol: float = 1e-4,
                 n_iter_no_change: int = 10, validation_fraction: float = 0.2,
                 alpha: float = 1e-4, dt_s: float = 0.125, linear_bypass: bool = True,
                 batch_size: int = 4,
                 random_state: np.random.Generator | int | None = None) -> None:
        super().__init__(hidden=hidden, max_epochs=max_epochs, learning_rate=learning_rate,
                         rho=rho, tol=tol, n_iter_no_change=n_iter_no_change,
                         validation_fraction=validation_fraction, alpha=alpha, dt_s=dt_s,
                         batch_size=batch_size, random_state=random_state)
        self.delays = delays
        self.linear_bypass = linear_bypass

    def fit(self, U: np.ndarray, y: np.ndarray) -> NARXBaseline:
        """Train series-parallel on normalized ``U`` and force ``y`` (linear term first)."""
        U = check_features(U)
        y = check_target(y, U.shape[0])
        R = narx_regressors(U, y, self.delays)
        self.lin_coef_ = np.zeros(R.shape[1])
        self.lin_intercept_ = 0.0
        if self.linear_bypass:
            # free_run: the paper's NARX (absolute force), trained first
            self._target_offset = np.zeros(U.shape[0])
            try:
                super().fit(U, y)
            finally:
                del self._target_offset
            self.free_run_net_ = self.net_
            self.free_run_epochs_ = self.n_epochs_
            # one_step: y(k-1) plus a network that learns the change from it
            self.lin_coef_[(self.delays + 1) * U.shape[1]] = 1.0
            self.lin_coef_[(self.delays + 1) * U.shape[1]] = 1.0
        self._target_offset = R @ self.lin_coef_ + self.lin_intercept_
        try:
            super().fit(U, y)
        finally:
            del self._target_offset
        if self.linear_bypass:
            # keep the network only if it improves the linear term on the last
            # validation_fraction of the identification data (held-out choice)
            tail = slice(int(round((1.0 - self.validation_fraction) * U.shape[0])), None)
            res = y[tail] - (R[tail] @ self.lin_coef_ + self.lin_intercept_)
            self.network_used_ = bool(
                np.mean((res - self.net_.predict(R[tail])) ** 2) < np.mean(res**2))
            if not self.network_used_:
                self.net_.coefs_[-1][:] = 0.0
                self.net_.intercepts_[-1][:] = 0.0
        return self

    def _regressors(self, U: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Series-parallel training: measured past force in the regressor."""
        return narx_regressors(U, y, self.delays)

    def _target(self, y: np.ndarray) -> np.ndarray:
        return y - self._target_offset

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate, shape (n_samples,); ``one_step`` needs the measured ``y``."""
        mode = self._mode(mode, y)
        U = check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__)
        if mode == "one_step":
            y = check_target(require_force(y, mode, "NARXBaseline"), U.shape[0])
            R = narx_regressors(U, y, self.delays)
            return self.net_.predict(R) + R @ self.lin_coef_ + self.lin_intercept_
        stream = self.streaming("free_run")
        return np.array([stream.step(u) for u in U])

    def _forward(self, mode: str) -> object:
        """The network used in ``mode`` (with its linear term in one_step)."""
        if mode == "free_run" and self.linear_bypass:
            return MLPForward(self.free_run_net_)
        return _Bypassed(MLPForward(self.net_), self.lin_coef_, self.lin_intercept_)

    def streaming(self, mode: str = "one_step", *, scaling: MinMaxScaling | None = None,
                  period_s: float | None = None) -> object:
        """A stream with preallocated delay lines (``period_s`` >= ``dt_s``)."""
        check_mode(mode, self.modes, "NARXBaseline")
        check_period(period_s, self.dt_s, "NARXBaseline")
        return scaled(_NARXStream(self._forward(mode), self.n_features_in_, self.delays, mode),
                      scaling)


class _Bypassed:
    """Network output plus the linear ARX term, for one regressor vector."""

    def __init__(self, forward: MLPForward, coef: np.ndarray, intercept: float) -> None:
        self._forward = forward
        self._dot = coef.copy().dot
        self._b = float(intercept)

    def __call__(self, r: np.ndarray) -> float:
        return self._forward(r) + float(self._dot(r)) + self._b


class _NARXStream:
    def __init__(self, forward: MLPForward, n_inputs: int, delays: int, mode: str) -> None:
        self._forward = forward
        self.mode = mode
        self.uses_force = mode == "one_step"
        m, d = n_inputs, delays
        self._r = np.zeros((d + 1) * m + d)
        nu = (d + 1) * m
        r = self._r
        # views for shifting the delay lines without allocation
        self._u_now, self._u_old_dst, self._u_old_src = r[:m], r[m:nu], r[:nu - m]
        self._y_now, self._y_old_dst, self._y_old_src = r[nu:nu + 1], r[nu + 1:], r[nu:nu + d - 1]
        self._u_tmp = np.empty(nu - m)
        self._y_tmp = np.empty(max(d - 1, 0))
        self._last = 0.0
        self._first = True

    def reset(self) -> None:
        """Zero the delay lines."""
        self._r[:] = 0.0
        self._last = 0.0
        self._first = True

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Shift in ``u(k)`` and ``y(k-1)`` (measured or own), return ``yhat(k)``."""
        np.copyto(self._u_tmp, self._u_old_src)
        np.copyto(self._u_old_dst, self._u_tmp)
        self._u_now[...] = u
        np.copyto(self._y_tmp, self._y_old_src)
        np.copyto(self._y_old_dst, self._y_tmp)
        if self.uses_force:
            if y_prev is None:
                if not self._first:
                    raise ModeError("one_step NARX stream needs y_prev (the force at k-1)")
                y_prev = 0.0
            self._y_now[0] = y_prev
        else:
            self._y_now[0] = self._last
        self._first = False
        self._last = self._forward(self._r)
        return self._last
