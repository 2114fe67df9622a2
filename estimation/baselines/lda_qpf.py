"""LDA + quadratic polynomial fit (Wang et al. 2019, as realized in the paper).

LDA (scikit-learn) projects the features to one dimension, trained to separate
discretized force levels; a quadratic ``yhat = c2 z^2 + c1 z + c0`` maps the
projection ``z`` to force by least squares.
"""

from __future__ import annotations

import numpy as np
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

from estimation.errors import ConstantInputError, check_features, check_mode, check_target
from estimation.normalize import MinMaxScaling
from estimation.streaming import scaled


class LDAQPF:
    """LDA to one dimension on force levels, then a quadratic to force.

    Parameters
    ----------
    n_levels : int
        Equal-width force levels over the identification force range used as
        LDA classes (empty levels are dropped; at least 2 must remain).
    degree : int
        Polynomial degree (paper: 2).

    Attributes
    ----------
    lda_ : LinearDiscriminantAnalysis
    projection_ : ndarray, shape (n_inputs,)
        ``z = (u - lda_.xbar_) @ projection_``.
    poly_ : ndarray, shape (degree + 1,)
        Polynomial coefficients, highest power first (``numpy.polyval``).
    """

    modes = ("one_step", "free_run")  # the force is never used: both modes coincide

    def __init__(self, *, n_levels: int = 5, degree: int = 2) -> None:
        self.n_levels = n_levels
        self.degree = degree

    def fit(self, U: np.ndarray, y: np.ndarray) -> LDAQPF:
        """Fit on normalized features ``U`` (n_samples, n_inputs) and force ``y`` (n_samples,)."""
        U = check_features(U)
        y = check_target(y, U.shape[0])
        span = np.ptp(y)
        if span == 0:
            raise ConstantInputError(f"force is constant ({y[0]!r}); LDA needs force levels")
        levels = np.minimum(((y - y.min()) / span * self.n_levels).astype(int),
                            self.n_levels - 1)
        if np.unique(levels).size < 2:
            raise ConstantInputError("fewer than 2 force levels populated; LDA needs 2 classes")
        self.lda_ = LinearDiscriminantAnalysis(n_components=1, solver="svd").fit(U, levels)
        self.projection_ = self.lda_.scalings_[:, 0].copy()
        z = self._project(U)
        self.poly_ = np.polyfit(z, y, self.degree)
        self.n_features_in_ = U.shape[1]
        return self

    def _project(self, U: np.ndarray) -> np.ndarray:
        return (U - self.lda_.xbar_) @ self.projection_

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str = "free_run") -> np.ndarray:
        """Force estimate, shape (n_samples,); ``y`` is ignored."""
        check_mode(mode, self.modes, "LDAQPF")
        U = check_features(U, n_inputs=self.n_features_in_)
        return np.polyval(self.poly_, self._project(U))

    def streaming(self, mode: str = "free_run", *,
                  scaling: MinMaxScaling | None = None) -> object:
        """A stream evaluating projection and polynomial per window."""
        check_mode(mode, self.modes, "LDAQPF")
        return scaled(_LDAQPFStream(self, mode), scaling)


class _LDAQPFStream:
    uses_force = False

    def __init__(self, est: LDAQPF, mode: str) -> None:
        self.mode = mode
        self._dot = est.projection_.dot
        self._z0 = float(est.lda_.xbar_ @ est.projection_)
        self._poly = [float(c) for c in est.poly_]

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Force estimate for features ``u(k)`` (normalized)."""
        z = float(self._dot(u)) - self._z0
        acc = 0.0
        for c in self._poly:  # Horner
            acc = acc * z + c
        return acc
