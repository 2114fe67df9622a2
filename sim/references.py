"""Pluggable grip-force reference signals for :class:`sim.hand.grasp_env.GraspEnv`.

A reference is any object with ``reset()`` and ``value(t_s) -> float``
(newtons at episode time ``t_s``). :func:`as_reference` turns the usual inputs
into one:

- a number: constant force;
- an array ``(n_samples,)``: a profile sampled every ``dt_s`` (default: the
  environment's control period), held after its end;
- a callable ``f(t_s) -> N``;
- a :class:`sim.recording.Recording` with ``force_n``: its measured force,
  zero-order held at ``1 / fs_hz``;
- a :class:`StreamReference`: values pushed step by step by the caller, e.g. an
  estimator's output (``env.set_reference(v)`` before each ``env.step``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, runtime_checkable

import numpy as np

from sim.errors import GriploopError
from sim.recording import Recording


class ReferenceSignalError(GriploopError, ValueError):
    """A force-reference input cannot be used."""


@runtime_checkable
class Reference(Protocol):
    """What the environment needs from a reference signal."""

    def reset(self) -> None:
        """Return to the start of the signal."""

    def value(self, t_s: float) -> float:
        """Reference grip force in N at episode time ``t_s``."""


class ConstantReference:
    """A constant force ``force_n`` (N)."""

    def __init__(self, force_n: float) -> None:
        self.force_n = _finite_nonneg(force_n, "reference")

    def reset(self) -> None:
        """Nothing to reset."""

    def value(self, t_s: float) -> float:
        """The constant force in N."""
        return self.force_n


class ProfileReference:
    """A force profile sampled every ``dt_s`` seconds, zero-order held.

    Parameters
    ----------
    force_n : array_like, shape (n_samples,)
        Force in N; sample ``k`` applies on ``[k dt_s, (k + 1) dt_s)`` and the
        last sample is held after the end.
    dt_s : float
        Sample interval in seconds.
    """

    def __init__(self, force_n: np.ndarray, dt_s: float) -> None:
        arr = np.asarray(force_n, dtype=float)
        if arr.ndim != 1 or arr.size == 0:
            raise ReferenceSignalError(
                f"reference profile: expected a non-empty 1-D array, found shape {arr.shape}"
            )
        if not np.all(np.isfinite(arr)) or arr.min() < 0:
            raise ReferenceSignalError("reference profile: expected finite forces >= 0 N, found "
                                 f"min {np.nanmin(arr):.3g} or non-finite values")
        if not (np.isfinite(dt_s) and dt_s > 0):
            raise ReferenceSignalError(
                f"reference dt_s: expected a positive interval, found {dt_s!r}")
        self.force_n = arr
        self.dt_s = float(dt_s)
        self._last = arr.size - 1

    def reset(self) -> None:
        """Nothing to reset (the profile is indexed by time)."""

    def value(self, t_s: float) -> float:
        """The held sample at ``t_s`` in N."""
        k = int(t_s / self.dt_s + 1e-9)
        return float(self.force_n[k if k < self._last else self._last])


class FunctionReference:
    """A callable ``fn(t_s) -> force_n``."""

    def __init__(self, fn: Callable[[float], float]) -> None:
        self.fn = fn

    def reset(self) -> None:
        """Nothing to reset."""

    def value(self, t_s: float) -> float:
        """``fn(t_s)`` in N."""
        return float(self.fn(t_s))


class StreamReference:
    """A reference pushed by the caller one value at a time (e.g. an estimator).

    The last pushed value is held until the next push.
    """

    def __init__(self, initial_n: float = 0.0) -> None:
        self.initial_n = _finite_nonneg(initial_n, "initial reference")
        self.current_n = self.initial_n

    def push(self, force_n: float) -> None:
        """Set the reference to ``force_n`` (N) from now on."""
        self.current_n = _finite_nonneg(force_n, "pushed reference")

    def reset(self) -> None:
        """Back to ``initial_n``."""
        self.current_n = self.initial_n

    def value(self, t_s: float) -> float:
        """The last pushed value in N."""
        return self.current_n


def as_reference(spec: object, dt_s: float) -> Reference:
    """Coerce a number, array, callable, Recording or Reference into a Reference.

    Parameters
    ----------
    spec : float, array_like, callable, Recording or Reference
        See the module docstring.
    dt_s : float
        Sample interval used for plain arrays (the control period).

    Raises
    ------
    ReferenceSignalError
        For anything else, or a Recording without ``force_n``.
    """
    if isinstance(spec, Reference):
        return spec
    if isinstance(spec, (int, float, np.floating, np.integer)) and not isinstance(spec, bool):
        return ConstantReference(float(spec))
    if isinstance(spec, Recording):
        if spec.force_n is None:
            raise ReferenceSignalError(
                f"{spec.source}: recording has no force_n to use as reference")
        return ProfileReference(np.clip(spec.force_n, 0.0, None), 1.0 / spec.fs_hz)
    if isinstance(spec, (list, tuple, np.ndarray)):
        return ProfileReference(np.asarray(spec, dtype=float), dt_s)
    if callable(spec):
        return FunctionReference(spec)
    raise ReferenceSignalError(
        "reference: expected a number, an array, a callable of time, a Recording or a "
        f"Reference, found {type(spec).__name__}"
    )


def _finite_nonneg(value: float, what: str) -> float:
    v = float(value)
    if not (np.isfinite(v) and v >= 0):
        raise ReferenceSignalError(f"{what}: expected a finite force >= 0 N, found {value!r}")
    return v
