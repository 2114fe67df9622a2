"""Confidence intervals and the few distribution functions they need, shared by the runners,
the commands and the report.

Plain numpy and the standard library (the Student t quantile and the chi-square tail are
closed forms for integer degrees of freedom, so the report does not import scipy.stats,
which costs it about a second); no plotting and no simulation, so any layer of
``scenarios`` may import it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

Z95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal."""


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a proportion ``k / n`` (95 % for the default ``z``).

    ``(nan, nan)`` when ``n == 0``.
    """
    if n == 0:
        return (float("nan"), float("nan"))
    p = k / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return (float(max(0.0, centre - half)), float(min(1.0, centre + half)))


def mean_interval(values: Sequence[float], level: float = 0.95) -> tuple[float, float, float]:
    """Mean of ``values`` and its Student-t confidence interval ``(mean, low, high)``.

    One value gives ``(value, nan, nan)``; none gives three NaNs.
    """
    x = np.asarray([v for v in values if v is not None and np.isfinite(v)], dtype=float)
    if x.size == 0:
        return (float("nan"),) * 3
    mean = float(np.mean(x))
    if x.size == 1:
        return (mean, float("nan"), float("nan"))
    half = float(t_quantile(0.5 + level / 2.0, x.size - 1) * np.std(x, ddof=1)
                 / np.sqrt(x.size))
    return (mean, mean - half, mean + half)


def _t_central(theta: float, df: int) -> float:
    """``P(|T| <= sqrt(df) tan(theta))`` for Student's t with integer ``df`` (Abramowitz and
    Stegun 26.7.3 and 26.7.4)."""
    s, c = math.sin(theta), math.cos(theta)
    if df % 2:  # odd: (2/pi) (theta + sin cos (1 + 2/3 cos^2 + 2*4/(3*5) cos^4 + ...))
        if df == 1:
            return 2.0 * theta / math.pi
        term, total = c, c
        for k in range(1, (df - 1) // 2):
            term *= c * c * (2 * k) / (2 * k + 1)
            total += term
        return 2.0 / math.pi * (theta + s * total)
    term, total = 1.0, 1.0  # even: sin (1 + 1/2 cos^2 + 1*3/(2*4) cos^4 + ...)
    for k in range(1, df // 2):
        term *= c * c * (2 * k - 1) / (2 * k)
        total += term
    return s * total


def t_quantile(p: float, df: int) -> float:
    """Quantile ``t`` with ``P(T <= t) = p`` of Student's t with integer ``df`` >= 1 degrees
    of freedom, to about 1e-12 (the closed-form distribution function, inverted by
    bisection over ``theta = atan(t / sqrt(df))``).

    Raises
    ------
    ValueError
        ``p`` outside (0, 1) or ``df`` < 1.
    """
    if not 0.0 < p < 1.0 or df < 1:
        raise ValueError(f"t_quantile: expected 0 < p < 1 and df >= 1, found p={p}, df={df}")
    if p == 0.5:
        return 0.0
    target = abs(2.0 * p - 1.0)  # P(|T| <= t)
    low, high = 0.0, math.pi / 2.0
    for _ in range(200):
        mid = 0.5 * (low + high)
        if _t_central(mid, df) < target:
            low = mid
        else:
            high = mid
        if high - low < 1e-15:
            break
    t = math.sqrt(df) * math.tan(0.5 * (low + high))
    return t if p > 0.5 else -t


def chi2_sf(x: float, dof: int) -> float:
    """``P(X > x)`` for a chi-square variable with integer ``dof`` >= 1 degrees of freedom
    (Abramowitz and Stegun 26.4.4 and 26.4.5: finite sums for integer ``dof``).

    Raises
    ------
    ValueError
        ``dof`` < 1.
    """
    if dof < 1:
        raise ValueError(f"chi2_sf: expected dof >= 1, found {dof}")
    if x <= 0.0:
        return 1.0
    if dof % 2 == 0:  # exp(-x/2) sum_{i < dof/2} (x/2)^i / i!
        term = total = 1.0
        for i in range(1, dof // 2):
            term *= x / 2.0 / i
            total += term
        return min(1.0, math.exp(-x / 2.0) * total)
    chi = math.sqrt(x)  # erfc(chi / sqrt 2) + sqrt(2/pi) exp(-x/2) sum chi^(2r-1) / (2r-1)!!
    term, total = chi, 0.0
    for r in range(1, (dof - 1) // 2 + 1):
        if r > 1:
            term *= x / (2 * r - 1)
        total += term
    return min(1.0, math.erfc(chi / math.sqrt(2.0))
               + math.sqrt(2.0 / math.pi) * math.exp(-x / 2.0) * total)
