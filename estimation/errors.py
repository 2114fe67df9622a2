"""Named errors of the estimation package and the input checks that raise them.

Every error subclasses a built-in (``ValueError`` or ``LookupError``) so that the
CLI prints it as one line; each message says what was expected and what was found.
"""

from __future__ import annotations

import numpy as np


class EstimationInputError(ValueError):
    """Features or force passed to an estimator are malformed (shape, NaN/inf)."""


class InsufficientDataError(ValueError):
    """Fewer samples than the model order or the parameter count needs."""


class ConstantInputError(ValueError):
    """An input or the force is constant, so it cannot be normalized or identified."""


class UnstableModelError(ValueError):
    """An identified model is unstable and was asked to run open loop (free run)."""


class RiccatiError(ValueError):
    """The Riccati equation has no stabilizing solution for the given model."""


class ModeError(ValueError):
    """An estimator was asked for a prediction mode it does not support."""


class UnknownEstimatorError(LookupError):
    """An estimator name is not in the registry."""


MODES = ("one_step", "free_run")


def check_mode(mode: str, supported: tuple[str, ...], who: str) -> str:
    """Return ``mode`` if ``who`` supports it, else raise :class:`ModeError`."""
    if mode not in supported:
        raise ModeError(f"{who}: mode must be one of {supported}, found {mode!r}")
    return mode


def require_force(y: np.ndarray | None, mode: str, who: str) -> np.ndarray:
    """Return ``y`` or raise :class:`ModeError` when a force-using mode lacks it."""
    if y is None:
        raise ModeError(f"{who}: mode {mode!r} needs the measured force y, got None")
    return y


def check_features(U: np.ndarray, *, name: str = "U", n_inputs: int | None = None) -> np.ndarray:
    """Validate a feature matrix and return it as float64.

    Parameters
    ----------
    U : array_like, shape (n_samples, n_inputs)
    name : str
        Argument name used in messages.
    n_inputs : int, optional
        Required number of columns (a fitted estimator's input count).

    Raises
    ------
    EstimationInputError
        Not 2-D, wrong column count, empty, or NaN/inf present.
    """
    arr = np.asarray(U, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[0] == 0 or arr.shape[1] == 0:
        raise EstimationInputError(
            f"{name} must be a non-empty 2-D array (n_samples, n_inputs), found shape {arr.shape}"
        )
    if n_inputs is not None and arr.shape[1] != n_inputs:
        raise EstimationInputError(
            f"{name} must have {n_inputs} columns as during fit, found {arr.shape[1]}"
        )
    if not np.all(np.isfinite(arr)):
        row, col = np.argwhere(~np.isfinite(arr))[0]
        raise EstimationInputError(
            f"{name} must be finite; found {arr[row, col]} at row {row}, column {col}"
        )
    return arr


def check_target(y: np.ndarray, n_samples: int, *, name: str = "y") -> np.ndarray:
    """Validate a force vector of length ``n_samples`` and return it as float64.

    Raises
    ------
    EstimationInputError
        Wrong shape or NaN/inf present.
    """
    arr = np.asarray(y, dtype=np.float64)
    if arr.ndim == 2 and arr.shape[1] == 1:
        arr = arr[:, 0]
    if arr.shape != (n_samples,):
        raise EstimationInputError(f"{name} must have shape ({n_samples},), found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        idx = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise EstimationInputError(f"{name} must be finite; found {arr[idx]} at index {idx}")
    return arr


def check_not_constant(U: np.ndarray, y: np.ndarray | None = None) -> None:
    """Raise :class:`ConstantInputError` if any column of ``U`` (or ``y``) is constant."""
    span = np.ptp(U, axis=0)
    if np.any(span == 0):
        col = int(np.flatnonzero(span == 0)[0])
        raise ConstantInputError(
            f"input column {col} is constant ({U[0, col]!r}); expected a varying feature"
        )
    if y is not None and np.ptp(y) == 0:
        raise ConstantInputError(f"force is constant ({y[0]!r}); expected a varying force")
