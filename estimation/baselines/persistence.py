"""Persistence baseline ``yhat(k) = y(k-1)``: what one-step scores must beat."""

from __future__ import annotations

import numpy as np
from sklearn.utils.validation import check_is_fitted

from estimation.base import ForceEstimator
from estimation.errors import check_features, check_mode, check_target, require_force
from estimation.normalize import MinMaxScaling
from estimation.streaming import DelayedLTIStream


class Persistence(ForceEstimator):
    """Predict the last measured force; ``one_step`` only (it needs the force).

    ``yhat(0) = 0`` (rest), matching a zero initial state of the other estimators.
    """

    modes = ("one_step",)

    def fit(self, U: np.ndarray, y: np.ndarray) -> Persistence:
        """Record the input count; nothing is learned."""
        U = check_features(U)
        check_target(y, U.shape[0])
        self.n_features_in_ = U.shape[1]
        return self

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """``[0, y(0), ..., y(n-2)]``, shape (n_samples,)."""
        check_is_fitted(self)
        U = check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__)
        mode = self._mode(mode, y)
        y = check_target(require_force(y, mode, "Persistence"), U.shape[0])
        return np.concatenate([[0.0], y[:-1]])

    def streaming(self, mode: str = "one_step", *,
                  scaling: MinMaxScaling | None = None) -> DelayedLTIStream:
        """A one-state delayed stream ``s(k) = y(k-1)``."""
        check_mode(mode, self.modes, "Persistence")
        return DelayedLTIStream(np.zeros((1, 1)), np.zeros((1, self.n_features_in_)),
                                np.ones(1), np.ones(1), mode=mode, scaling=scaling)
