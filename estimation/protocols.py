"""What an estimator and its stream provide (structural types, ``typing.Protocol``).

Every estimator of :mod:`estimation.registry` satisfies :class:`Estimator` (in the
scikit-learn form: hyperparameters stored verbatim by ``__init__``, fitted
attributes ending in ``_``), and ``estimator.streaming(mode)`` returns a
:class:`Stream` for sample-by-sample use in a control loop. Both are
``runtime_checkable``: ``isinstance(obj, Estimator)`` checks the members exist.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import numpy as np


@runtime_checkable
class Stream(Protocol):
    """An estimator running one feature window at a time, allocation-free per step."""

    def reset(self) -> None:
        """Return to the state before the first step."""

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """One estimate.

        Parameters
        ----------
        u : ndarray, shape (n_inputs,)
            Features of the current window.
        y_prev : float, optional
            Measured force of the previous window (``one_step`` mode only).

        Returns
        -------
        float
            Force estimate (N through a :class:`~estimation.pipeline.ForcePipeline`,
            normalized units for a bare estimator).
        """


@runtime_checkable
class Estimator(Protocol):
    """A grip-force estimator: scikit-learn's ``fit`` / ``predict`` plus modes and streams.

    Attributes
    ----------
    modes : tuple of str
        Supported prediction modes, among ``"one_step"`` and ``"free_run"``.
    """

    modes: tuple[str, ...]

    def fit(self, U: np.ndarray, y: np.ndarray) -> Any:
        """Identify the estimator on features ``U`` (n_samples, n_inputs) and force ``y``
        (n_samples,); returns ``self``."""

    def predict(self, U: np.ndarray, y: np.ndarray | None = None, *,
                mode: str | None = None) -> np.ndarray:
        """Force estimate, shape (n_samples,); ``y`` is the measured force (``one_step``)."""

    def streaming(self, mode: str = ..., **options: Any) -> Stream:
        """A :class:`Stream` of the fitted estimator in ``mode``."""
