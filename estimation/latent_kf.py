"""Deployable Kalman decoder with force as the latent state (Wu et al. 2006 style).

Model, fitted by least squares on identification data (centred with the
identification means)::

    x(k+1) = a x(k) + w,    w ~ N(0, W)         force dynamics (scalar)
    z(k)   = H x(k) + q,    q ~ N(0, Qz)        sEMG features as observations

with ``x`` the normalized force minus its mean and ``z`` the normalized features
minus theirs. The steady-state filter ``xhat(k|k) = (1 - K H) a xhat(k-1|k-1) + K z(k)``
(``K`` the filter gain from the Riccati equation) needs only sEMG at run time and
uses the current window, so ``one_step`` and ``free_run`` coincide.
"""

from __future__ import annotations

import numpy as np

from estimation.base import ForceEstimator
from estimation.errors import (
    InsufficientDataError,
    check_features,
    check_mode,
    check_not_constant,
    check_target,
)
from estimation.kalman import design_kalman
from estimation.normalize import MinMaxScaling
from estimation.streaming import DirectLTIStream, direct_response


class LatentKalman(ForceEstimator):
    """Latent-force Kalman decoder.

    Parameters
    ----------
    ridge : float
        Added to the observation-noise covariance as ``ridge * trace(Qz) / m * I``:
        MAV, RMS and WL of one channel are nearly collinear, so ``Qz`` is
        close to singular without it.

    Attributes
    ----------
    a_ : float
        Force transition coefficient.
    W_ : float
        Process-noise variance.
    H_ : ndarray, shape (n_inputs, 1)
    Qz_ : ndarray, shape (n_inputs, n_inputs)
    x_mean_ : float
    z_mean_ : ndarray, shape (n_inputs,)
    filter_gain_, predictor_gain_ : ndarray, shape (1, n_inputs)
    """

    modes = ("one_step", "free_run")  # the force is never used: both modes coincide

    def __init__(self, *, ridge: float = 1e-3) -> None:
        self.ridge = ridge

    def fit(self, U: np.ndarray, y: np.ndarray) -> LatentKalman:
        """Fit on normalized features ``U`` (n_samples, n_inputs) and force ``y``.

        Raises
        ------
        InsufficientDataError, ConstantInputError, RiccatiError
        """
        U = check_features(U)
        y = check_target(y, U.shape[0])
        n, m = U.shape
        if n < m + 3:
            raise InsufficientDataError(
                f"latent Kalman decoder with {m} inputs needs at least {m + 3} samples, "
                f"found n_samples = {n} (n_features = {m})"
            )
        check_not_constant(U, y)
        self.x_mean_ = float(y.mean())
        self.z_mean_ = U.mean(axis=0)
        x = y - self.x_mean_
        Z = U - self.z_mean_
        self.a_ = float(x[1:] @ x[:-1] / (x[:-1] @ x[:-1]))
        self.W_ = float(np.var(x[1:] - self.a_ * x[:-1]))
        self.H_ = (Z.T @ x / (x @ x))[:, None]
        resid = Z - x[:, None] * self.H_[:, 0]
        Qz = np.atleast_2d(np.cov(resid, rowvar=False, bias=True))  # (1, 1) for one input
        self.Qz_ = Qz + self.ridge * np.trace(Qz) / m * np.eye(m)
        kf = design_kalman(np.array([[self.a_]]), self.H_, np.array([[self.W_]]), self.Qz_)
        self.filter_gain_ = kf.filter_gain
        self.predictor_gain_ = kf.predictor_gain
        self.n_features_in_ = m
        return self

    def _system(self) -> dict[str, np.ndarray | float]:
        K = self.filter_gain_.reshape(1, -1)
        F = np.array([[(1.0 - float((K @ self.H_)[0, 0])) * self.a_]])
        return {"F": F, "G": K, "h": np.ones(1), "d": np.zeros(self.n_features_in_),
                "g": -(K @ self.z_mean_), "d0": self.x_mean_}

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Filtered force ``xhat(k|k) + x_mean_``, shape (n_samples,); ``y`` is ignored."""
        self._mode(mode, y)
        U = check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__)
        s = self._system()
        return direct_response(s["F"], s["G"], s["h"], s["d"], U, g=s["g"], d0=s["d0"])

    def streaming(self, mode: str = "free_run", *,
                  scaling: MinMaxScaling | None = None) -> DirectLTIStream:
        """A :class:`~estimation.streaming.DirectLTIStream` of the steady-state filter."""
        check_mode(mode, self.modes, "LatentKalman")
        s = self._system()
        return DirectLTIStream(s["F"], s["G"], s["h"], s["d"], g=s["g"], d0=s["d0"], mode=mode,
                               scaling=scaling)
