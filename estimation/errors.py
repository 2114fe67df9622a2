"""Named errors of the estimation package and the input checks that raise them.

Every error subclasses a built-in (``ValueError`` or ``LookupError``) so that the
CLI prints it as one line; each message says what was expected and what was found.
"""

from __future__ import annotations

import warnings

import numpy as np

from sim.errors import GriploopError


class EstimationInputError(GriploopError, ValueError):
    """Features or force passed to an estimator are malformed (shape, NaN/inf)."""


class InsufficientDataError(GriploopError, ValueError):
    """Fewer samples than the model order or the parameter count needs."""


class ConstantInputError(GriploopError, ValueError):
    """An input or the force is constant, so it cannot be normalized or identified."""


class UnstableModelError(GriploopError, ValueError):
    """An identified model is unstable and was asked to run open loop (free run)."""


class RiccatiError(GriploopError, ValueError):
    """The Riccati equation has no stabilizing solution for the given model."""


class ModeError(GriploopError, ValueError):
    """An estimator was asked for a prediction mode it does not support."""


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


def _bad_value(value: float) -> str:
    """``NaN`` or ``inf`` / ``-inf`` as scikit-learn spells them in messages."""
    return "NaN" if np.isnan(value) else str(value)


def check_features(U: np.ndarray, *, name: str = "U", n_inputs: int | None = None,
                   who: str = "the estimator", min_samples: int = 1) -> np.ndarray:
    """Validate a feature matrix and return it as float64.

    Messages carry scikit-learn's phrases (``Reshape your data``, ``X has 3
    features, but ... is expecting 4 features as input``, ``Complex data not
    supported``, ``sparse``) so that its estimator checks recognize them.

    Parameters
    ----------
    U : array_like, shape (n_samples, n_inputs)
    name : str
        Argument name used in messages.
    n_inputs : int, optional
        Required number of columns (a fitted estimator's input count).
    who : str
        Estimator name used in messages.
    min_samples : int
        Fewest rows accepted.

    Raises
    ------
    EstimationInputError
        Sparse, complex, not 2-D, wrong column count, too few rows, or NaN/inf present.
    """
    import scipy.sparse
    if scipy.sparse.issparse(U):
        raise EstimationInputError(
            f"{name} is a sparse matrix; sparse input is not supported, pass a dense array")
    arr = np.asarray(U)
    if np.iscomplexobj(arr):
        raise EstimationInputError(f"Complex data not supported; {name} must be real")
    arr = np.asarray(arr, dtype=np.float64)
    if arr.ndim != 2:
        raise EstimationInputError(
            f"{name} must be a non-empty 2-D array (n_samples, n_inputs), found shape {arr.shape}; "
            "Reshape your data with .reshape(-1, 1) for a single input or .reshape(1, -1) "
            "for a single sample"
        )
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        what = "0 sample(s)" if arr.shape[0] == 0 else "0 feature(s)"
        raise EstimationInputError(
            f"{name} must be a non-empty 2-D array (n_samples, n_inputs), found "
            f"{what} (shape={arr.shape}) while a minimum of 1 is required."
        )
    if n_inputs is not None and arr.shape[1] != n_inputs:
        raise EstimationInputError(
            f"X has {arr.shape[1]} features, but {who} is expecting {n_inputs} features as "
            f"input ({name} must have {n_inputs} columns as during fit)"
        )
    if arr.shape[0] < min_samples:
        raise InsufficientDataError(
            f"{who} needs at least {min_samples} samples, found n_samples = {arr.shape[0]}")
    if not np.all(np.isfinite(arr)):
        row, col = np.argwhere(~np.isfinite(arr))[0]
        raise EstimationInputError(
            f"{name} must be finite; found {_bad_value(arr[row, col])} at row {row}, column {col}"
        )
    return arr


def check_target(y: np.ndarray, n_samples: int, *, name: str = "y") -> np.ndarray:
    """Validate a force vector of length ``n_samples`` and return it as float64.

    A column vector (n_samples, 1) is accepted with scikit-learn's
    :class:`~sklearn.exceptions.DataConversionWarning`.

    Raises
    ------
    EstimationInputError
        ``None``, wrong shape or NaN/inf present.
    """
    if y is None:
        raise EstimationInputError(
            f"{name} is None: the estimator requires y to be passed, but the target y is None")
    arr = np.asarray(y)
    if np.iscomplexobj(arr):
        raise EstimationInputError(f"Complex data not supported; {name} must be real")
    arr = np.asarray(arr, dtype=np.float64)
    if arr.ndim == 2 and arr.shape[1] == 1:
        from sklearn.exceptions import DataConversionWarning  # only for this warning

        warnings.warn(
            f"A column-vector {name} was passed when a 1d array was expected; "
            "use y.ravel() (shape (n_samples,))", DataConversionWarning, stacklevel=3)
        arr = arr[:, 0]
    if arr.shape != (n_samples,):
        raise EstimationInputError(f"{name} must have shape ({n_samples},), found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        idx = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise EstimationInputError(
            f"{name} must be finite; found {_bad_value(arr[idx])} at index {idx}")
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
