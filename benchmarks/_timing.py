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


def goal_line(goal: str, figure: float, unit: str, *, limit: float, better: str = "lower",
              reference: str = "") -> bool:
    """Print one goal as ``GOAL | goal | figure | reference | met/not met`` and return met.

    ``make bench`` collects these lines (``benchmarks/run_all.py`` turns them into the
    speed table, docs/results/speed.md), so every benchmark states each goal in this one format.

    Parameters
    ----------
    goal : str
        What is measured and its target, e.g. ``"MPC solve median <= 0.05 ms"``.
    figure : float
        The measured value, in ``unit``.
    unit : str
        Unit of ``figure`` and ``limit`` (``"ms"``, ``"x"``, ``"M/s"``...).
    limit : float
        The goal's threshold in ``unit``.
    better : {"lower", "higher"}
        Whether the figure must stay at or below (``lower``) or reach (``higher``) ``limit``.
    reference : str
        The reference measured in the same run, with its value (``"osqp 0.81 ms"``), or
        ``""`` when the goal is absolute.
    """
    if better not in ("lower", "higher"):
        raise ValueError(f"better: expected 'lower' or 'higher', found {better!r}")
    met = figure <= limit if better == "lower" else figure >= limit
    print(f"GOAL | {goal} | {figure:.4g} {unit} | {reference or '-'} | "
          f"{'met' if met else 'NOT MET'}", flush=True)
    return met
