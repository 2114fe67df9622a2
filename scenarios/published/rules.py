"""How a published finding is judged against griploop's figure: the board's three rules.

Every row of the board (:mod:`scenarios.published.findings`) compares a figure griploop
measured, with its 95 % interval, against what a publication reports. Three kinds of
finding, three rules, written down before any full run (docs/PUBLISHED.md):

``Range`` (a published figure or range: "70-95 blocks per minute", "at least 95 %")
    *agrees* when griploop's figure lies in the published range; *disagrees* when its
    whole 95 % interval lies outside it; otherwise (the figure outside, the interval
    reaching in) *inconclusive*. A figure without an interval (one subject) is
    inconclusive unless it lies in the range.
``Direction`` (an effect: "vibration lowers the time per block")
    *agrees* when the effect's 95 % interval excludes zero in the published direction;
    *disagrees* when it excludes zero the other way; otherwise *inconclusive*.
``Band`` (no effect: "feedback changes the score by less than the test's noise")
    *agrees* when the effect's 95 % interval lies within ``+-half_width``; *disagrees*
    when it lies wholly outside that band; otherwise *inconclusive*.

A finding made of several parts (a range and two directions) agrees when every part
agrees, disagrees when any part disagrees, and is otherwise inconclusive: :func:`combine`.

The intervals come from the same subjects and seeds under each condition (paired):
:func:`paired_differences` pairs two conditions by subject; :func:`bootstrap_interval`
resamples subjects (a seeded :class:`numpy.random.Generator`) for a ratio or a median.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from scenarios.stats import mean_interval, wilson_interval

AGREES, DISAGREES, INCONCLUSIVE, FAILED = "agrees", "disagrees", "inconclusive", "failed"
#: Every verdict a row may carry.
VERDICTS = (AGREES, DISAGREES, INCONCLUSIVE, FAILED)
BOOTSTRAP_RESAMPLES = 2000
"""Resamples of subjects for a bootstrap interval (percentile method)."""

Interval = tuple[float, float] | None


@dataclass(frozen=True)
class Range:
    """A published figure or range ``[lo, hi]`` (module notes); ``math.inf`` for no bound."""

    lo: float
    hi: float

    def verdict(self, figure: float | None, ci95: Interval) -> str:
        """``agrees`` / ``disagrees`` / ``inconclusive`` for ``figure`` and its interval."""
        if figure is None or not math.isfinite(figure):
            return INCONCLUSIVE
        if self.lo <= figure <= self.hi:
            return AGREES
        if ci95 is not None and (ci95[1] < self.lo or ci95[0] > self.hi):
            return DISAGREES
        return INCONCLUSIVE


@dataclass(frozen=True)
class Direction:
    """A published effect's sign: ``+1`` (griploop's effect should be above zero) or ``-1``."""

    sign: int

    def verdict(self, ci95: Interval) -> str:
        """The effect's interval against zero (module notes)."""
        if ci95 is None or not all(math.isfinite(v) for v in ci95):
            return INCONCLUSIVE
        lo, hi = self.sign * ci95[0], self.sign * ci95[1]
        if min(lo, hi) > 0.0:
            return AGREES
        if max(lo, hi) < 0.0:
            return DISAGREES
        return INCONCLUSIVE


@dataclass(frozen=True)
class Band:
    """No effect beyond ``+-half_width`` (module notes)."""

    half_width: float

    def verdict(self, ci95: Interval) -> str:
        """The effect's interval against the band."""
        if ci95 is None or not all(math.isfinite(v) for v in ci95):
            return INCONCLUSIVE
        if -self.half_width <= ci95[0] and ci95[1] <= self.half_width:
            return AGREES
        if ci95[0] > self.half_width or ci95[1] < -self.half_width:
            return DISAGREES
        return INCONCLUSIVE


def combine(verdicts: Sequence[str]) -> str:
    """All parts agree: agrees; any part disagrees: disagrees; otherwise inconclusive."""
    if any(v == DISAGREES for v in verdicts):
        return DISAGREES
    if verdicts and all(v == AGREES for v in verdicts):
        return AGREES
    return INCONCLUSIVE


# ------------------------------------------------------------------ figures
def _interval(lo: float, hi: float) -> Interval:
    return None if not (math.isfinite(lo) and math.isfinite(hi)) else (float(lo), float(hi))


def mean_with_interval(values: Sequence[float | None]) -> tuple[float | None, Interval]:
    """Mean over subjects and its Student-t 95 % interval (None where undefined)."""
    mean, lo, hi = mean_interval([v for v in values if v is not None])
    return (None if math.isnan(mean) else mean), _interval(lo, hi)


def rate_with_interval(k: int, n: int) -> tuple[float | None, Interval]:
    """``k / n`` and its Wilson 95 % interval (None when ``n`` is 0)."""
    if n == 0:
        return None, None
    lo, hi = wilson_interval(k, n)
    return k / n, (lo, hi)


def paired_differences(a: Mapping[int, float | None],
                       b: Mapping[int, float | None]) -> list[float]:
    """``a[s] - b[s]`` for every subject ``s`` with a value in both (a paired design)."""
    return [float(a[s]) - float(b[s]) for s in sorted(set(a) & set(b))
            if a[s] is not None and b[s] is not None]


def bootstrap_interval(statistic: Callable[[np.ndarray], float], data: np.ndarray,
                       rng: np.random.Generator,
                       resamples: int = BOOTSTRAP_RESAMPLES) -> Interval:
    """Percentile 95 % interval of ``statistic`` over rows of ``data`` resampled with
    replacement (rows: subjects, kept whole so paired columns stay paired).

    Parameters
    ----------
    statistic : callable
        ``statistic(rows) -> float`` on an array shaped like ``data``.
    data : ndarray, shape (n_subjects, ...)
    rng : numpy.random.Generator
        The resampling stream (seeded by the caller).

    Returns
    -------
    (lo, hi) or None
        None with fewer than 2 rows, or when no resample gives a finite value.
    """
    data = np.asarray(data, dtype=float)
    n = data.shape[0]
    if n < 2:
        return None
    picks = rng.integers(0, n, size=(resamples, n))
    values = np.array([statistic(data[p]) for p in picks])
    values = values[np.isfinite(values)]
    if values.size == 0:
        return None
    lo, hi = np.percentile(values, [2.5, 97.5])
    return float(lo), float(hi)
