"""The paper's state-space model identified for free running (simulation-error refinement).

RLS (the paper's method, :class:`~estimation.state_space.SSEstimator`) minimizes the
one-step equation error: with the measured force in its states the model scores well
one step ahead, but run on sEMG alone it can drift or be unstable. Here the same
structure ``x(k+1) = A x(k) + B u(k) + b``, ``yhat(k) = C x(k)`` with ``C = [1, 0, ..., 0]``
(``b`` an input offset, 0 at the start: min-max features at rest are not exactly 0)
keeps the RLS ``A`` (scaled inside ``max_pole`` if RLS left it unstable) and
re-estimates ``(B, b)`` to minimize the **simulation** error of the free-running
model on the identification data. For a fixed ``A`` that error is linear in
``(B, b)``, so this is a ridge regression (closed form, milliseconds) with a pull
towards the RLS ``B`` whose weight is chosen on a contiguous validation split (the
last ``validation_fraction``).

This is the deployable variant of the paper's model: ``free_run`` only. The paper's
exact method is left unchanged in :mod:`estimation.state_space`.
"""

from __future__ import annotations

import numpy as np

from estimation.deployable import check_period
from estimation.errors import EstimationInputError, check_features, check_mode, check_target
from estimation.normalize import MinMaxScaling
from estimation.state_space import SSEstimator
from estimation.streaming import delayed_response


def _unpack(theta: np.ndarray, n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    return theta[:n * n].reshape(n, n), theta[n * n:].reshape(n, m)


def _with_ones(U: np.ndarray) -> np.ndarray:
    return np.hstack([U, np.ones((U.shape[0], 1))])


class SimulationErrorSS(SSEstimator):
    """Paper's SS structure, RLS start, refined on the free-run simulation error.

    Parameters
    ----------
    order : int
        Model order n (paper: 4).
    penalties : tuple of float
        Candidate ridge weights pulling ``(B, b)`` towards the RLS estimate
        (relative to the number of samples); chosen on validation.
    max_pole : float
        Largest pole magnitude kept for ``A`` (an RLS ``A`` beyond it is scaled in).
    validation_fraction : float
        Last fraction of the identification data used to choose the penalty.
    compress : {"sqrt", "none"}
        Feature compression before identification (``sqrt(max(u, 0))``, as
        :class:`~estimation.deployable.LogRidge`): the simulated force then follows
        a concave sEMG-force law and extrapolates better above the identification range.
    dt_s : float
        Sample time in seconds.

    Attributes
    ----------
    A_, B_, C_ : ndarray
        Refined model (``C_ = [1, 0, ..., 0]``); ``A_rls_``, ``B_rls_`` the start.
    penalty_ : float
        Chosen ridge weight.
    """

    modes = ("free_run",)
    # Fixed settings of the RLS start (SSEstimator's hyperparameters, not this
    # estimator's: class attributes so get_params/clone see only the ones below).
    kalman = False
    forgetting = 1.0
    theta0 = 0.3
    p0 = 1000.0
    noise_regressor = True
    kalman_method = "scipy"

    def __init__(self, *, order: int = 4,
                 penalties: tuple[float, ...] = (1e-4, 1e-3, 1e-2, 1e-1, 1.0),
                 max_pole: float = 0.995, validation_fraction: float = 0.3,
                 compress: str = "sqrt", dt_s: float = 0.125) -> None:
        self.order = order
        self.dt_s = dt_s
        self.compress = compress
        self.penalties = penalties
        self.max_pole = max_pole
        self.validation_fraction = validation_fraction

    def _regressors(self, A: np.ndarray, U: np.ndarray) -> np.ndarray:
        """``Phi[k, (i, l)]``: free-run output at ``k`` per unit of ``B[i, l]`` (inputs + 1)."""
        n = A.shape[0]
        Uo = _with_ones(U)
        N, m = Uo.shape
        r = np.empty((N, n))  # r[j] = C A^j
        r[0] = np.eye(1, n)[0]
        for j in range(1, N):
            r[j] = r[j - 1] @ A
        # yhat(k) = sum_j r[j] B u(k-1-j): convolve r_i with u_l, shifted by one
        size = 1 << int(np.ceil(np.log2(2 * N)))
        fr = np.fft.rfft(r, size, axis=0)[:, :, None]
        fu = np.fft.rfft(Uo, size, axis=0)[:, None, :]
        conv = np.fft.irfft(fr * fu, size, axis=0)[:N]  # (N, n, m)
        Phi = np.zeros((N, n * m))
        Phi[1:] = conv[:-1].reshape(N - 1, n * m)
        return Phi

    @staticmethod
    def _ridge(Phi: np.ndarray, y: np.ndarray, penalty: float, beta0: np.ndarray) -> np.ndarray:
        lam = penalty * Phi.shape[0]
        lhs = Phi.T @ Phi + lam * np.eye(Phi.shape[1])
        return np.linalg.solve(lhs, Phi.T @ y + lam * beta0)

    def fit(self, U: np.ndarray, y: np.ndarray) -> SimulationErrorSS:
        """RLS identification, then ``(B, b)`` re-estimated on the simulation error."""
        U = check_features(U)
        y = check_target(y, U.shape[0])
        if self.compress not in ("sqrt", "none"):
            raise EstimationInputError(
                f"compress: expected 'sqrt' or 'none', found {self.compress!r}")
        U = self._compress(U)
        super().fit(U, y)
        n, m = self.order_, U.shape[1] + 1
        A = self.A_.copy()
        rho = float(np.max(np.abs(np.linalg.eigvals(A))))
        if rho >= self.max_pole:  # start from a stable model
            A *= 0.95 * self.max_pole / rho
        self.A_rls_, self.B_rls_ = self.A_.copy(), self.B_.copy()
        beta0 = np.hstack([self.B_, np.zeros((n, 1))]).ravel()
        Phi = self._regressors(A, U)
        n_tr = int(round((1.0 - self.validation_fraction) * U.shape[0]))
        scores = []
        for penalty in self.penalties:
            beta = self._ridge(Phi[:n_tr], y[:n_tr], penalty, beta0)
            scores.append((float(np.mean((Phi[n_tr:] @ beta - y[n_tr:]) ** 2)), penalty))
        self.validation_mse_, self.penalty_ = min(scores)
        B = self._ridge(Phi, y, self.penalty_, beta0).reshape(n, m)
        self.A_, self.B_, self.offset_ = A, B[:, :-1].copy(), B[:, -1].copy()
        self.poles_ = np.linalg.eigvals(self.A_)
        self.stable_ = bool(np.max(np.abs(self.poles_)) < 1.0)
        self._lti_cache = {}
        return self

    def _compress(self, U: np.ndarray) -> np.ndarray:
        return np.sqrt(np.maximum(U, 0.0)) if self.compress == "sqrt" else U

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Free-run estimate, shape (n_samples,); ``y`` is ignored (sEMG only)."""
        self._mode(mode, y)
        U = self._compress(check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__))
        B = np.hstack([self.B_, self.offset_[:, None]])
        return delayed_response(self.A_, B, self.C_[0], _with_ones(U))

    def streaming(self, mode: str = "free_run", *, scaling: MinMaxScaling | None = None,
                  period_s: float | None = None) -> _SimStream:
        """An allocation-free stream equal to :meth:`predict` (``period_s`` >= ``dt_s``)."""
        check_mode(mode, self.modes, type(self).__name__)
        check_period(period_s, self.dt_s, type(self).__name__)
        return _SimStream(self, scaling)


class _SimStream:
    """``x(k) = A x(k-1) + B u(k-1) + b``, ``yhat(k) = x_1(k)``, ``x(0) = 0``."""

    uses_force = False
    mode = "free_run"

    def __init__(self, est: SimulationErrorSS, scaling: MinMaxScaling | None) -> None:
        m = est.n_features_in_
        self._u_min = np.zeros(m) if scaling is None else scaling.u_min.copy()
        self._u_span = np.ones(m) if scaling is None else scaling.u_span.copy()
        self._sqrt = est.compress == "sqrt"
        self._u = np.empty(m)
        self._B = est.B_.copy()
        self._b = est.offset_.copy()
        self._A = est.A_.copy()
        self._y_min = 0.0 if scaling is None else float(scaling.y_min_n)
        self._y_span = 1.0 if scaling is None else float(scaling.y_span_n)
        n = est.order_
        self._x = np.zeros(n)
        self._next = np.zeros(n)
        self._tmp = np.zeros(n)
        self._started = False

    def reset(self) -> None:
        """Back to rest: zero state."""
        self._x[:] = 0.0
        self._next[:] = 0.0
        self._started = False

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Raw features ``u(k)`` in, force estimate ``yhat(k)`` (N with scaling) out."""
        if self._started:
            np.copyto(self._x, self._next)
        self._started = True
        yhat = float(self._x[0])
        # prepare x(k+1) = A x(k) + B u(k) + b
        np.dot(self._A, self._x, out=self._next)
        np.subtract(u, self._u_min, out=self._u)
        np.divide(self._u, self._u_span, out=self._u)
        if self._sqrt:
            np.maximum(self._u, 0.0, out=self._u)
            np.sqrt(self._u, out=self._u)
        np.dot(self._B, self._u, out=self._tmp)
        self._next += self._tmp
        self._next += self._b
        return yhat * self._y_span + self._y_min
