"""Timing helpers shared by the benchmark scripts, on the standard library's :mod:`timeit`."""

from __future__ import annotations

import statistics
import timeit
from collections.abc import Callable


def time_call(fn: Callable[[], object], *, repeat: int = 5) -> float:
    """Median wall time of one call of ``fn`` in seconds.

    :meth:`timeit.Timer.autorange` picks the number of calls (1, 2, 5, 10, ...)
    that lasts at least 0.2 s; the timer then takes ``repeat`` measurements of
    that many calls (garbage collection off, as ``timeit`` does) and the median
    per call is returned. Fast functions are thus timed over many calls and
    slow ones once.
    """
    timer = timeit.Timer(fn)
    number, _ = timer.autorange()
    return statistics.median(timer.repeat(repeat=repeat, number=number)) / number
