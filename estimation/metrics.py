"""Accuracy and smoothness metrics of a force estimate, as pure functions.

``r2_score`` and ``nrmse_fit`` follow the paper's eqs. (20)-(21)::

    R^2   = 1 - sum (y - yhat)^2 / sum (y - ybar)^2
    NRMSE = 1 - sqrt(sum (y - yhat)^2) / sqrt(sum (y - ybar)^2)

so that ``NRMSE = 1 - sqrt(1 - R^2)`` whenever both use the same mean ``ybar``
(1 is a perfect fit; both can be negative for estimates worse than the mean).
Both are invariant to an affine rescaling of ``y`` and ``yhat`` together, so they
are identical in newtons and in normalized units.

``r2_score`` and ``rmse`` are computed by scikit-learn (``sklearn.metrics.r2_score``,
``root_mean_squared_error``) after this module's input checks; ``nrmse_fit`` (the
paper's fit, not in scikit-learn), ``r2_score(..., y_mean=...)`` (R^2 about a
given mean, which scikit-learn does not offer) and ``total_variation_rate`` are
computed here. scikit-learn is imported by the first score that needs it: an episode
that scores nothing (the oracle reference) does not load it.
"""

from __future__ import annotations

import numpy as np

from estimation.errors import EstimationInputError


def _pair(y: np.ndarray, y_hat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(y, dtype=np.float64)
    y_hat = np.asarray(y_hat, dtype=np.float64)
    if y.ndim != 1 or y.shape != y_hat.shape or y.size < 2:
        raise EstimationInputError(
            f"y and y_hat must be 1-D of equal length >= 2, found {y.shape} and {y_hat.shape}"
        )
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(y_hat))):
        raise EstimationInputError("y and y_hat must be finite; found NaN or inf")
    return y, y_hat


def _sse_sst(y: np.ndarray, y_hat: np.ndarray, y_mean: float | None) -> tuple[float, float]:
    y, y_hat = _pair(y, y_hat)
    mean = float(np.mean(y)) if y_mean is None else float(y_mean)
    sse = float(np.sum((y - y_hat) ** 2))
    sst = float(np.sum((y - mean) ** 2))
    if sst == 0.0:
        raise EstimationInputError("y is constant (zero total sum of squares); R^2 undefined")
    return sse, sst


def r2_score(y: np.ndarray, y_hat: np.ndarray, *, y_mean: float | None = None) -> float:
    """Coefficient of determination, paper eq. (21).

    Parameters
    ----------
    y, y_hat : ndarray, shape (n_samples,)
        Reference and estimate (any consistent unit).
    y_mean : float, optional
        The mean ``ybar``; default the mean of ``y``.
    """
    y, y_hat = _pair(y, y_hat)
    sse, sst = _sse_sst(y, y_hat, y_mean)  # also refuses a constant y (R^2 undefined)
    if y_mean is None:
        import sklearn.metrics

        return float(sklearn.metrics.r2_score(y, y_hat))
    return 1.0 - sse / sst


def nrmse_fit(y: np.ndarray, y_hat: np.ndarray, *, y_mean: float | None = None) -> float:
    """Normalized-RMSE goodness of fit, paper eq. (20): 1 - ||y - yhat|| / ||y - ybar||."""
    sse, sst = _sse_sst(y, y_hat, y_mean)
    return 1.0 - float(np.sqrt(sse / sst))


def rmse(y: np.ndarray, y_hat: np.ndarray) -> float:
    """Root-mean-square error in the unit of ``y`` (newtons for forces)."""
    import sklearn.metrics

    y, y_hat = _pair(y, y_hat)
    return float(sklearn.metrics.root_mean_squared_error(y, y_hat))


def total_variation_rate(signal: np.ndarray, dt_s: float) -> float:
    """Volatility of a reference: total variation per second, ``sum |diff| / ((n-1) dt_s)``.

    Parameters
    ----------
    signal : ndarray, shape (n_samples,)
        E.g. an estimated force in newtons; the result is then in N/s.
    dt_s : float
        Sample interval in seconds.
    """
    s = np.asarray(signal, dtype=np.float64)
    if s.ndim != 1 or s.size < 2 or not np.all(np.isfinite(s)):
        raise EstimationInputError(f"signal must be finite 1-D with >= 2 samples, found {s.shape}")
    if not dt_s > 0:
        raise EstimationInputError(f"dt_s must be positive, found {dt_s!r}")
    return float(np.sum(np.abs(np.diff(s))) / ((s.size - 1) * dt_s))
