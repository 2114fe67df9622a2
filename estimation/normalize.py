"""Min-max normalization of features and force to 0..1 (the paper's preprocessing).

Fitted on identification data only; validation data may fall outside 0..1.

Why not ``sklearn.preprocessing.MinMaxScaler``: its ranges are the same
(``data_min_``, ``data_range_`` equal ``u_min``, ``u_span`` bit for bit, tested),
but it transforms as ``X * scale_ + min_`` with ``scale_ = 1 / range``, which
rounds differently from ``(X - min) / span`` (1 ulp on about 60 % of the entries
of a calibration set; the RLS identification with ``P(0) = 1000 I`` turns that
into ~1e-13 differences in SS_KF estimates). The allocation-free streams fold
exactly ``(u - u_min) / u_span`` into their matrices, and the boosted trees of
``gbt`` compare thresholds on it, so batch and stream must share this
arithmetic; it also covers the force, which ``MinMaxScaler`` (2-D only) does not.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimation.errors import check_features, check_not_constant, check_target


@dataclass(frozen=True)
class MinMaxScaling:
    """Affine maps ``u_n = (u - u_min_) * u_inv_span_`` and ``y_n = (y - y_min_n) / y_span_n``.

    Attributes
    ----------
    u_min : ndarray, shape (n_inputs,)
        Per-feature minimum on identification data (feature units).
    u_span : ndarray, shape (n_inputs,)
        Per-feature range (max - min), > 0.
    y_min_n, y_span_n : float
        Force minimum and range in newtons, range > 0.
    """

    u_min: np.ndarray
    u_span: np.ndarray
    y_min_n: float
    y_span_n: float

    @classmethod
    def fit(cls, U: np.ndarray, y_n: np.ndarray) -> MinMaxScaling:
        """Learn the ranges of ``U`` (n_samples, n_inputs) and ``y_n`` (n_samples,) in N.

        Raises
        ------
        ConstantInputError
            A feature column or the force is constant.
        """
        U = check_features(U, who="min-max scaling", min_samples=2)
        y_n = check_target(y_n, U.shape[0])
        # np.ptp is max - min: compute each extreme once and reuse them
        u_min = U.min(axis=0)
        u_span = U.max(axis=0) - u_min
        y_min = float(y_n.min())
        y_span = float(y_n.max()) - y_min
        if not (u_span.all() and y_span):
            check_not_constant(U, y_n)
        return cls(u_min, u_span, y_min, y_span)

    def transform_u(self, U: np.ndarray) -> np.ndarray:
        """Normalized features, shape (n_samples, n_inputs)."""
        return (np.asarray(U, dtype=np.float64) - self.u_min) / self.u_span

    def transform_y(self, y_n: np.ndarray) -> np.ndarray:
        """Normalized force from newtons."""
        return (np.asarray(y_n, dtype=np.float64) - self.y_min_n) / self.y_span_n

    def inverse_y(self, y_norm: np.ndarray) -> np.ndarray:
        """Force in newtons from normalized force."""
        return np.asarray(y_norm, dtype=np.float64) * self.y_span_n + self.y_min_n
