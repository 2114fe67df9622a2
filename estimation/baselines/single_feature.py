"""Linear force fit from one feature type on every channel (the paper's Fig. 7A).

``features_mav`` uses the MAV columns of channels 6, 7, 8 (channel-major layout
``ch6_mav, ch6_rms, ch6_wl, ch7_mav, ...``), likewise RMS and WL:
``yhat(k) = c0 + sum_ch c_ch f_ch(k)`` by least squares.
"""

from __future__ import annotations

import numpy as np

from estimation.base import ForceEstimator
from estimation.errors import EstimationInputError, check_features, check_mode, check_target
from estimation.features import FEATURES
from estimation.normalize import MinMaxScaling
from estimation.streaming import DirectLTIStream


class SingleFeatureLinear(ForceEstimator):
    """Least-squares line from one feature type (all channels) to force.

    Parameters
    ----------
    feature : {"mav", "rms", "wl"}
    features : tuple of str
        Feature order within each channel's block of columns.

    Attributes
    ----------
    columns_ : ndarray of int
        Columns of ``U`` used.
    coef_ : ndarray, shape (n_inputs,)
        Coefficients over all columns (zero outside ``columns_``).
    intercept_ : float
    """

    modes = ("one_step", "free_run")  # the force is never used: both modes coincide

    def __init__(self, *, feature: str = "mav", features: tuple[str, ...] = FEATURES) -> None:
        self.feature = feature
        self.features = features

    def fit(self, U: np.ndarray, y: np.ndarray) -> SingleFeatureLinear:
        """Fit the line on normalized features ``U`` (n_samples, n_inputs) and force ``y``."""
        U = check_features(U)
        y = check_target(y, U.shape[0])
        if self.feature not in self.features or U.shape[1] % len(self.features):
            raise EstimationInputError(
                f"feature {self.feature!r} with per-channel features {self.features} does not "
                f"fit {U.shape[1]} input columns"
            )
        pos = self.features.index(self.feature)
        self.columns_ = np.arange(pos, U.shape[1], len(self.features))
        design = np.hstack([np.ones((U.shape[0], 1)), U[:, self.columns_]])
        sol, *_ = np.linalg.lstsq(design, y, rcond=None)
        self.coef_ = np.zeros(U.shape[1])
        self.coef_[self.columns_] = sol[1:]
        self.intercept_ = float(sol[0])
        self.n_features_in_ = U.shape[1]
        return self

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """``intercept_ + U @ coef_``, shape (n_samples,); ``y`` is ignored."""
        self._mode(mode, y)
        U = check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__)
        return U @ self.coef_ + self.intercept_

    def streaming(self, mode: str = "free_run", *,
                  scaling: MinMaxScaling | None = None) -> DirectLTIStream:
        """A static :class:`~estimation.streaming.DirectLTIStream`."""
        check_mode(mode, self.modes, "SingleFeatureLinear")
        return DirectLTIStream(np.zeros((0, 0)), np.zeros((0, self.n_features_in_)),
                               np.zeros(0), self.coef_, d0=self.intercept_, mode=mode,
                               scaling=scaling)
