"""LDA + quadratic polynomial fit (Wang et al. 2019, as realized in the paper).

LDA (scikit-learn) projects the features to one dimension, trained to separate
discretized force levels; a quadratic ``yhat = c2 z^2 + c1 z + c0`` maps the
projection ``z`` to force by least squares.

Guarded extrapolation: the quadratic is used inside the projections seen in
identification, ``[z_lo, z_hi]``; outside, it continues along its tangent at the
nearer end (never turning back: a slope of the wrong sign, against the overall
force trend, is replaced by 0). A raw quadratic bends over above the
identification range and gave negative R^2 on virtual subjects whose strongest
squeeze lies in the validation half.
"""

from __future__ import annotations

import numpy as np
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

from estimation.base import ForceEstimator
from estimation.errors import ConstantInputError, check_features, check_mode, check_target
from estimation.normalize import MinMaxScaling
from estimation.streaming import scaled


class LDAQPF(ForceEstimator):
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
        U = check_features(U, who="LDAQPF", min_samples=2)
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
        self.z_range_ = (float(z.min()), float(z.max()))
        trend = float(np.sign(np.polyfit(z, y, 1)[0])) or 1.0
        deriv = np.polyder(self.poly_)
        self.edges_ = tuple(
            (zb, float(np.polyval(self.poly_, zb)),
             float(np.polyval(deriv, zb)) if np.polyval(deriv, zb) * trend > 0 else 0.0)
            for zb in self.z_range_)
        self.n_features_in_ = U.shape[1]
        return self

    def _map(self, z: np.ndarray) -> np.ndarray:
        """Guarded polynomial: quadratic inside the identification range, tangent outside."""
        (z_lo, y_lo, s_lo), (z_hi, y_hi, s_hi) = self.edges_
        out = np.polyval(self.poly_, np.clip(z, z_lo, z_hi))
        out = np.where(z < z_lo, y_lo + s_lo * (z - z_lo), out)
        return np.where(z > z_hi, y_hi + s_hi * (z - z_hi), out)

    def _project(self, U: np.ndarray) -> np.ndarray:
        return (U - self.lda_.xbar_) @ self.projection_

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate, shape (n_samples,); ``y`` is ignored."""
        self._mode(mode, y)
        U = check_features(U, n_inputs=self.n_features_in_,
                           who=type(self).__name__)
        return self._map(self._project(U))

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
        (self._z_lo, self._y_lo, self._s_lo), (self._z_hi, self._y_hi, self._s_hi) = est.edges_

    def reset(self) -> None:
        """Stateless: nothing to reset."""

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Force estimate for features ``u(k)`` (normalized)."""
        z = float(self._dot(u)) - self._z0
        if z < self._z_lo:
            return self._y_lo + self._s_lo * (z - self._z_lo)
        if z > self._z_hi:
            return self._y_hi + self._s_hi * (z - self._z_hi)
        acc = 0.0
        for c in self._poly:  # Horner
            acc = acc * z + c
        return acc
