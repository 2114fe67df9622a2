"""scikit-learn conventions shared by every force estimator.

Every estimator of the registry (and :class:`~estimation.pipeline.ForcePipeline`)
derives from :class:`ForceEstimator`, i.e. from scikit-learn's ``RegressorMixin``
and ``BaseEstimator``: ``sklearn.base.clone``, ``get_params`` / ``set_params``,
``score`` and ``sklearn.model_selection.cross_val_score`` work on them.

Mode when ``predict`` is called without ``mode`` (:func:`resolve_mode`):

- ``predict(U)`` (no measured force): the deployable mode ``"free_run"``; an
  estimator with ``one_step`` only (persistence) raises :class:`~estimation.errors.ModeError`.
- ``predict(U, y)``: ``"one_step"`` where supported (the measured force is
  used because it was given), else ``"free_run"``.

``score(U, y)`` is R^2 (:func:`sklearn.metrics.r2_score`) in the deployable mode
(``free_run``) where one exists; for a ``one_step``-only estimator it is the
one-step R^2, with ``y`` as the measured force up to ``k - 1``. Pass ``mode=``
to score another mode. Time-series estimators depend on sample order, so
``cross_val_score`` should use an unshuffled ``KFold`` (contiguous folds).
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.metrics import r2_score as _sk_r2_score
from sklearn.utils.validation import check_is_fitted

from estimation.errors import ModeError, check_mode

#: The mode that needs no measured force (what a prosthesis can run).
DEPLOYABLE_MODE = "free_run"


def resolve_mode(mode: str | None, modes: tuple[str, ...], y: object, who: str) -> str:
    """The prediction mode: ``mode`` if given, else the default described above.

    Parameters
    ----------
    mode : str or None
        Requested mode; ``None`` picks the default.
    modes : tuple of str
        Modes the estimator supports.
    y : array_like or None
        The measured force passed to ``predict`` (only tested against ``None``).
    who : str
        Estimator name for messages.

    Raises
    ------
    ModeError
        Unsupported ``mode``, or ``mode=None`` without ``y`` for an estimator that
        has no deployable mode.
    """
    if mode is not None:
        return check_mode(mode, modes, who)
    if y is not None and "one_step" in modes:
        return "one_step"
    if DEPLOYABLE_MODE in modes:
        return DEPLOYABLE_MODE
    raise ModeError(f"{who} needs the measured force: call predict(U, y) "
                    f"(modes {modes}, no sEMG-only 'free_run')")


def score_mode(modes: tuple[str, ...]) -> str:
    """Mode used by ``score``: ``free_run`` where supported, else ``one_step``."""
    return DEPLOYABLE_MODE if DEPLOYABLE_MODE in modes else "one_step"


class ForceEstimator(RegressorMixin, BaseEstimator):
    """Base of the force estimators: scikit-learn's estimator API plus ``modes``.

    Subclasses store their keyword-only hyperparameters verbatim in ``__init__``,
    validate them in ``fit``, and implement ``fit(U, y)``,
    ``predict(U, y=None, *, mode=None)`` and ``streaming(mode, ...)``.
    """

    #: Prediction modes the estimator supports.
    modes: tuple[str, ...] = ("one_step", "free_run")

    def _mode(self, mode: str | None, y: object) -> str:
        """Raise ``NotFittedError`` before ``fit``; else the mode ``predict`` uses."""
        check_is_fitted(self)
        return resolve_mode(mode, tuple(self.modes), y, type(self).__name__)

    def divergence(self, mode: str) -> str | None:
        """Why running the fitted estimator in ``mode`` would diverge, or ``None``.

        The default reads ``stable_`` and ``poles_`` (identified linear models):
        an unstable model diverges in ``free_run``, where no measured force
        corrects it.
        """
        if mode != DEPLOYABLE_MODE or getattr(self, "stable_", True) is not False:
            return None
        poles = np.round(np.abs(np.asarray(getattr(self, "poles_", []))), 3).tolist()
        return f"identified model is unstable (poles {poles}); free run would diverge"

    def score(self, X: np.ndarray, y: np.ndarray, sample_weight: np.ndarray | None = None,
              *, mode: str | None = None) -> float:
        """R^2 of the estimate (:func:`sklearn.metrics.r2_score`).

        Parameters
        ----------
        X : ndarray, shape (n_samples, n_inputs)
            Features.
        y : ndarray, shape (n_samples,)
            Measured force (the reference; in ``one_step`` also the force up to ``k - 1``).
        sample_weight : ndarray, shape (n_samples,), optional
        mode : {"one_step", "free_run"}, optional
            Default: ``free_run`` where supported, else ``one_step``.
        """
        mode = score_mode(tuple(self.modes)) if mode is None else mode
        y_arr = np.asarray(y, dtype=np.float64)
        y_hat = self.predict(X, y_arr if mode == "one_step" else None, mode=mode)
        return float(_sk_r2_score(y_arr.reshape(y_hat.shape), y_hat, sample_weight=sample_weight))

    def __sklearn_tags__(self):  # noqa: D105
        tags = super().__sklearn_tags__()
        # The time-series estimators keep a state across rows (sample order
        # matters), so scikit-learn's i.i.d. toy problems are not their task.
        tags.regressor_tags.poor_score = True
        return tags
