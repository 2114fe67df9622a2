"""Behavioural checks of a registered estimator, for plugin authors.

:func:`check_estimator` builds the estimator as a scenario does
(``make_estimator(name)``: the registered parameters, ``random_state`` =
:data:`SEED` if it takes a seed, ``dt_s`` = :data:`STANDARD_DT_S` if it takes the
feature period) and fits it on :func:`standard_data`. It checks, in order (a failure
of ``build`` or ``fit`` stops the checks that need it):

``build``
    The registered factory builds, and both the bare estimator and its
    :class:`~estimation.pipeline.ForcePipeline` satisfy
    :class:`estimation.protocols.Estimator`.
``modes``
    The estimator's ``modes`` are those it registered.
``fit``
    ``fit(U, y)`` raises nothing.
``finite_prediction``
    In every declared mode, ``predict`` returns a finite estimate of shape (n_samples,).
``stream_matches_predict``
    In every declared mode, the stream (``streaming(mode)``, ``reset()``, then ``step(u)``
    on each window, with the previous measured force in ``one_step``) returns
    ``predict(U, y, mode)`` within :data:`ATOL_N` + :data:`RTOL` x ``|predict|``.
``stream_reset_reproduces``
    ``reset()`` and the same windows again repeat the stream's first run (same tolerance).
``refit_reproduces``
    Fitting the same estimator again on the same data repeats its predictions (same
    tolerance): no state carried from one fit to the next, no unseeded randomness.

Each returns :class:`sim.checks.CheckFailure` records, one line each.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from estimation.protocols import Estimator
from estimation.registry import estimator_info, make_estimator
from sim.checks import CheckFailure, raised

#: Seed of the standard data and of an estimator that takes ``random_state``.
SEED = 0
#: Windows of the standard data (30 s of a calibration session at 125 ms).
STANDARD_WINDOWS = 240
#: Feature columns of the standard data: MAV, RMS and WL of 3 channels (the layout of
#: armband channels 6-8, for which pretrained ensembles ship).
STANDARD_INPUTS = 9
#: Feature period, s (the paper's 125 ms window increment).
STANDARD_DT_S = 0.125
#: Absolute tolerance of the stream and reproduction checks, N.
ATOL_N = 1e-6
#: Relative tolerance of the stream and reproduction checks.
RTOL = 1e-6

_FAMILY = "estimator"


def standard_data(seed: int = SEED, n_windows: int = STANDARD_WINDOWS,
                  n_inputs: int = STANDARD_INPUTS) -> tuple[np.ndarray, np.ndarray]:
    """The standard synthetic calibration data of the checks (seeded, ``numpy.random.Generator``).

    A latent grip intent ``x`` in 0..1 (a low-passed uniform sequence, rescaled) drives
    every feature column with its own gain plus rectified noise; the force is
    ``2 + 18 x`` N plus 0.2 N noise.

    Parameters
    ----------
    seed : int
        Seed of the generator.
    n_windows : int
        Feature windows (samples).
    n_inputs : int
        Feature columns.

    Returns
    -------
    U : ndarray, shape (n_windows, n_inputs)
        Positive features.
    y : ndarray, shape (n_windows,)
        Measured force, N.
    """
    rng = np.random.default_rng(seed)
    x = np.zeros(n_windows)
    drive = rng.uniform(size=n_windows)
    for k in range(1, n_windows):
        x[k] = 0.9 * x[k - 1] + 0.1 * drive[k]
    x = (x - x.min()) / (x.max() - x.min())
    gains = rng.uniform(0.5, 1.5, size=n_inputs)
    U = 0.05 + np.outer(x, gains) + 0.02 * np.abs(rng.normal(size=(n_windows, n_inputs)))
    y = 2.0 + 18.0 * x + 0.2 * rng.normal(size=n_windows)
    return U, y


def check_estimator(name: str) -> list[CheckFailure]:
    """Check the registered estimator ``name`` (the checks of the module docstring).

    Parameters
    ----------
    name : str
        A registered estimator (:func:`estimation.registry.estimator_names`).

    Returns
    -------
    list of CheckFailure
        One per failed check; empty when the estimator passes.

    Raises
    ------
    estimation.registry.UnknownEstimatorError
        ``name`` is not registered.
    """
    info = estimator_info(name)  # raises for an unknown name, before any check
    modes = tuple(info["modes"])
    params: dict[str, Any] = {}
    if info["takes_seed"]:
        params["random_state"] = SEED
    if info["takes_dt"]:
        params["dt_s"] = STANDARD_DT_S
    try:
        bare = make_estimator(name, normalize=False, **params)
        est = make_estimator(name, **params)
    except Exception as exc:  # a plugin's factory may raise anything: that is the finding
        return [_failure(name, "build", "the registered factory to build the estimator",
                         raised(exc))]
    failures = _check_protocol(name, bare, est, modes)
    if failures and failures[0].check == "build":
        return failures
    U, y = standard_data()
    try:
        est.fit(U, y)
    except Exception as exc:
        return [*failures, _failure(name, "fit", "fit(U, y) on the standard data", raised(exc))]
    for mode in modes:
        failures += _check_mode(name, est, mode, U, y)
    return failures + _check_refit(name, est, modes, U, y)


def _failure(name: str, check: str, expected: str, found: str) -> CheckFailure:
    return CheckFailure(_FAMILY, name, check, expected, found)


def _tolerance() -> str:
    return f"within {ATOL_N:g} N + {RTOL:g} x |predict|"


def _first_difference(a: np.ndarray, b: np.ndarray) -> int | None:
    """Index of the first sample where ``a`` is not ``b`` within the tolerance, or ``None``."""
    same = np.isclose(a, b, rtol=RTOL, atol=ATOL_N, equal_nan=True)
    bad = np.flatnonzero(~same)
    return int(bad[0]) if bad.size else None


def _check_protocol(name: str, bare: Any, est: Any, modes: tuple[str, ...]) -> list[CheckFailure]:
    """``build`` (both satisfy the protocol) and ``modes`` (as registered)."""
    for what, obj in (("estimator", bare), ("pipeline", est)):
        if not isinstance(obj, Estimator):
            missing = [m for m in ("modes", "fit", "predict", "streaming") if not hasattr(obj, m)]
            return [_failure(name, "build", f"the {what} to have modes, fit, predict and "
                             "streaming", f"a {type(obj).__name__} without {', '.join(missing)}")]
    if tuple(bare.modes) != modes:
        return [_failure(name, "modes", f"modes {modes} as registered",
                         f"{tuple(bare.modes)}")]
    return []


def _stream(est: Any, mode: str, U: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two runs of ``est.streaming(mode)`` over ``U``, a ``reset()`` before each."""
    stream = est.streaming(mode)
    runs = []
    for _ in range(2):
        stream.reset()
        out = [stream.step(U[0])]
        for k in range(1, U.shape[0]):
            out.append(stream.step(U[k], float(y[k - 1]) if mode == "one_step" else None))
        runs.append(np.asarray(out, dtype=float))
    return runs[0], runs[1]


def _check_mode(name: str, est: Any, mode: str, U: np.ndarray,
                y: np.ndarray) -> list[CheckFailure]:
    """``finite_prediction``, ``stream_matches_predict``, ``stream_reset_reproduces``."""
    try:
        batch = np.asarray(est.predict(U, y if mode == "one_step" else None, mode=mode),
                           dtype=float)
    except Exception as exc:
        return [_failure(name, "finite_prediction", f"predict(U, mode={mode!r}) to run",
                         raised(exc))]
    if batch.shape != (U.shape[0],) or not np.all(np.isfinite(batch)):
        n_bad = int(np.sum(~np.isfinite(batch)))
        return [_failure(name, "finite_prediction", f"{mode}: a finite estimate of shape "
                         f"({U.shape[0]},)", f"shape {batch.shape}, {n_bad} not finite")]
    try:
        first, again = _stream(est, mode, U, y)
    except Exception as exc:
        return [_failure(name, "stream_matches_predict", f"{mode}: streaming({mode!r}) to "
                         "reset and step over the standard data", raised(exc))]
    failures = []
    k = _first_difference(first, batch)
    if k is not None:
        failures.append(_failure(
            name, "stream_matches_predict", f"{mode}: step() equal to predict() {_tolerance()}",
            f"{first[k]:.6g} N instead of {batch[k]:.6g} N at window {k}"))
    k = _first_difference(again, first)
    if k is not None:
        failures.append(_failure(
            name, "stream_reset_reproduces", f"{mode}: after reset() the stream's first run "
            f"{_tolerance()}", f"{again[k]:.6g} N instead of {first[k]:.6g} N at window {k}"))
    return failures


def _check_refit(name: str, est: Any, modes: tuple[str, ...], U: np.ndarray,
                 y: np.ndarray) -> list[CheckFailure]:
    """``refit_reproduces``: fit the same estimator again, predict again."""
    try:
        before = [np.asarray(est.predict(U, y if m == "one_step" else None, mode=m), dtype=float)
                  for m in modes]
        est.fit(U, y)
        after = [np.asarray(est.predict(U, y if m == "one_step" else None, mode=m), dtype=float)
                 for m in modes]
    except Exception as exc:
        return [_failure(name, "refit_reproduces", "a second fit on the same data to run",
                         raised(exc))]
    for mode, a, b in zip(modes, after, before, strict=True):
        k = _first_difference(a, b) if a.shape == b.shape else 0
        if k is not None:
            found = (f"{a[k]:.6g} N instead of {b[k]:.6g} N at window {k}" if a.shape == b.shape
                     else f"shape {a.shape} instead of {b.shape}")
            return [_failure(name, "refit_reproduces", f"{mode}: the first fit's predictions "
                             f"{_tolerance()}", found)]
    return []
