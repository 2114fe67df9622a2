"""Small timing helpers shared by the benchmark scripts."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np


def time_call(fn: Callable[[], object], *, repeat: int = 5, min_time_s: float = 0.2) -> float:
    """Median wall time of one call of ``fn`` in seconds.

    Each of ``repeat`` measurements runs ``fn`` enough times to last at least
    ``min_time_s`` and divides by the count, so fast functions are timed over
    many calls and slow ones once.
    """
    samples = []
    for _ in range(repeat):
        count, start = 0, time.perf_counter()
        while True:
            fn()
            count += 1
            elapsed = time.perf_counter() - start
            if elapsed >= min_time_s:
                break
        samples.append(elapsed / count)
    return float(np.median(samples))
