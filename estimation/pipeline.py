"""An estimator together with its normalization: raw features and newtons in and out.

This is what a closed-loop runner uses::

    from estimation import make_estimator
    est = make_estimator("ss_kf").fit(fs.X, fs.y)        # features as extracted, force in N
    force_n = est.predict(X_new, mode="free_run")          # newtons
    stream = est.streaming(mode="free_run")                # raw features in, newtons out
    stream.reset(); f = stream.step(u)                     # allocation-free

Normalization (min-max to 0..1, the paper's preprocessing) is learned in
``fit`` from the calibration data only and folded into the stream.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from sklearn.utils.validation import check_is_fitted

from estimation.base import ForceEstimator, resolve_mode
from estimation.errors import check_features, check_target
from estimation.normalize import MinMaxScaling

if TYPE_CHECKING:
    from estimation.protocols import Estimator, Stream


class ForcePipeline(ForceEstimator):
    """Min-max normalization around a normalized-unit estimator.

    A scikit-learn meta-estimator: ``get_params(deep=True)`` lists the wrapped
    estimator's hyperparameters as ``estimator__<name>``, and ``clone`` copies
    it unfitted. ``fit`` fits ``estimator`` itself (kept for the callers that
    read ``pipe.estimator.A_``); ``estimator_`` is the same fitted object.

    Parameters
    ----------
    estimator : object
        Unfitted estimator with ``fit``, ``predict``, ``streaming`` and ``modes``.

    Attributes
    ----------
    scaling_ : MinMaxScaling
        Feature and force ranges of the calibration data.
    estimator_ : object
        The fitted wrapped estimator (``estimator`` itself).
    modes : tuple of str
        The wrapped estimator's supported modes.
    """

    def __init__(self, estimator: Estimator) -> None:
        self.estimator = estimator

    @property
    def modes(self) -> tuple[str, ...]:
        """Modes the wrapped estimator supports."""
        return tuple(self.estimator.modes)

    def fit(self, U: np.ndarray, y: np.ndarray) -> ForcePipeline:
        """Learn the scaling and fit the estimator.

        Parameters
        ----------
        U : ndarray, shape (n_samples, n_inputs)
            Raw features.
        y : ndarray, shape (n_samples,)
            Measured force in newtons.
        """
        U = check_features(U)
        y = check_target(y, U.shape[0])
        self.scaling_ = MinMaxScaling.fit(U, y)
        self.estimator.fit(self.scaling_.transform_u(U), self.scaling_.transform_y(y))
        self.estimator_ = self.estimator
        self.n_features_in_ = U.shape[1]
        return self

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate in newtons, shape (n_samples,). ``y`` (N) for ``one_step``.

        Without ``mode``: ``one_step`` when ``y`` is given (and supported), else
        the deployable ``free_run`` (see :func:`estimation.base.resolve_mode`).
        """
        check_is_fitted(self)
        U = check_features(U, n_inputs=self.n_features_in_, who="ForcePipeline")
        mode = resolve_mode(mode, self.modes, y, type(self.estimator).__name__)
        folded = getattr(self.estimator, "predict_scaled", None)
        if folded is not None:
            # linear estimators fold the scaling into their filter weights: no
            # normalized copy of U, one pass over it (estimation/streaming.py)
            y_n = None if y is None else check_target(y, U.shape[0])
            return folded(U, y_n, mode=mode, scaling=self.scaling_)
        y_norm = None if y is None else self.scaling_.transform_y(check_target(y, U.shape[0]))
        y_hat = self.estimator.predict(self.scaling_.transform_u(U), y_norm, mode=mode)
        return self.scaling_.inverse_y(y_hat)

    def divergence(self, mode: str) -> str | None:
        """Why the wrapped estimator would diverge in ``mode``, or ``None``
        (:meth:`estimation.base.ForceEstimator.divergence`)."""
        check = getattr(self.estimator, "divergence", None)
        return None if check is None else check(mode)

    def streaming(self, mode: str = "one_step", **options: object) -> Stream:
        """A stream taking raw features and the force in N, returning N.

        ``options`` go to the estimator's ``streaming`` (e.g. ``period_s``, the
        interval between steps in seconds, for estimators that check it).
        """
        return self.estimator.streaming(mode, scaling=self.scaling_, **options)
