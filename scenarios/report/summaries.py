"""Outcome rates by combination of factors, and paired differences between controllers."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.outcomes import OUTCOMES, row_outcome
from scenarios.report.factors import CONTROLLER_FACTOR, factor_value, hashable_value, levels
from scenarios.stats import t_quantile, wilson_interval


@dataclass(frozen=True)
class SummaryRow:
    """Outcomes and metrics of the episodes of one combination of the swept factors.

    Attributes
    ----------
    levels : tuple
        The combination, one value per factor (in :func:`outcome_summary`'s order).
    n : int
        Episodes.
    counts : dict of str to int
        Episodes per outcome of :data:`~scenarios.outcomes.OUTCOMES`.
    intervals : dict of str to (float, float)
        95 % Wilson interval of each outcome's rate.
    tracking_rmse_n, contact_peak_ratio, slip_distance_m : float
        Means over the episodes that report the metric (``nan`` if none does).
    phase_margin_deg : float
        Mean phase margin at the held force (``nan`` if no episode held a force).
    worst_phase_margin_deg : float
        Minimum over episodes of the worst phase margin over visited forces.
    """

    levels: tuple
    n: int
    counts: dict[str, int]
    intervals: dict[str, tuple[float, float]]
    tracking_rmse_n: float
    contact_peak_ratio: float
    slip_distance_m: float
    phase_margin_deg: float
    worst_phase_margin_deg: float

    def rate(self, outcome: str) -> float:
        """Fraction of the episodes with ``outcome``."""
        return self.counts[outcome] / self.n


def _values(results: Sequence[Mapping[str, Any]], name: str) -> np.ndarray:
    out = [float(r[name]) for r in results if r.get(name) is not None]
    return np.array([v for v in out if np.isfinite(v)], dtype=float)


def _mean(values: np.ndarray) -> float:
    return float(values.mean()) if values.size else float("nan")


def outcome_summary(episodes: Sequence[Mapping[str, Any]],
                    factors: Sequence[str]) -> list[SummaryRow]:
    """One :class:`SummaryRow` per combination of ``factors`` present in the episodes.

    Rows are sorted by the factors' levels (numbers ascending, names in store order).
    """
    groups: dict[tuple, list[Mapping[str, Any]]] = {}
    for e in episodes:
        key = tuple(hashable_value(factor_value(e, p)) for p in factors)
        groups.setdefault(key, []).append(e["result"])
    order = [{v: i for i, v in enumerate(levels(episodes, p))} for p in factors]
    out = []
    for key in sorted(groups, key=lambda k: tuple(o[v] for o, v in zip(order, k, strict=True))):
        results = groups[key]
        outcomes = [row_outcome(r) for r in results]
        counts = {o: outcomes.count(o) for o in OUTCOMES}
        worst = _values(results, "worst_phase_margin_deg")
        out.append(SummaryRow(
            key, len(results), counts,
            {o: wilson_interval(c, len(results)) for o, c in counts.items()},
            _mean(_values(results, "tracking_rmse_n")),
            _mean(_values(results, "contact_peak_ratio")),
            _mean(_values(results, "slip_distance_m")),
            _mean(_values(results, "phase_margin_deg")),
            float(worst.min()) if worst.size else float("nan"),
        ))
    return out


# ---------------------------------------------------------------- paired comparison


#: Paired metrics: name -> (label, function of an episode result giving a float or None).
PAIRED_METRICS: dict[str, tuple[str, Any]] = {
    "held": ("held rate", lambda r: float(row_outcome(r) == "held")),
    "tracking_rmse_n": ("tracking RMSE (N)", lambda r: r.get("tracking_rmse_n")),
    "slip_distance_m": ("slip distance (m)", lambda r: r.get("slip_distance_m")),
    "contact_peak_ratio": ("contact peak ratio", lambda r: r.get("contact_peak_ratio")),
}


@dataclass(frozen=True)
class PairedDifference:
    """Mean difference ``other - baseline`` of one metric over paired scenarios.

    Two episodes are paired when every swept factor but the controller, and the
    seed, are equal. The interval is the 95 % t interval of the mean of the
    paired differences (``nan`` for fewer than two pairs).

    Attributes
    ----------
    baseline, other : str
        Controllers.
    metric : str
        Key of :data:`PAIRED_METRICS`.
    n_pairs : int
        Pairs where both episodes report the metric.
    baseline_mean, other_mean : float
        Means of the metric over those pairs.
    mean_diff, ci_low, ci_high : float
        Mean paired difference and its 95 % interval.
    """

    baseline: str
    other: str
    metric: str
    n_pairs: int
    baseline_mean: float
    other_mean: float
    mean_diff: float
    ci_low: float
    ci_high: float


def paired_differences(episodes: Sequence[Mapping[str, Any]], factors: Sequence[str],
                       controller: str = CONTROLLER_FACTOR,
                       metrics: Sequence[str] = tuple(PAIRED_METRICS)) -> list[PairedDifference]:
    """Paired differences between each pair of controllers on the same scenarios.

    Parameters
    ----------
    episodes : sequence of dict
        Episode rows (``result`` and ``config``).
    factors : sequence of str
        The swept factors (:func:`~scenarios.report.factors.swept_factors`); must include
        ``controller``.
    controller : str
        The factor compared.
    metrics : sequence of str
        Keys of :data:`PAIRED_METRICS`.

    Returns
    -------
    list of PairedDifference
        For each controller pair ``(a, b)`` with ``a`` before ``b`` in store
        order, each metric: ``b - a``. Empty if the controller does not vary.
        When a scenario appears more than once per controller (repeated rows),
        the first row is used.
    """
    if controller not in factors:
        return []
    others = [p for p in factors if p != controller]
    by_controller: dict[Any, dict[tuple, Mapping[str, Any]]] = {}
    for e in episodes:
        key = (*(hashable_value(factor_value(e, p)) for p in others),
               e["result"].get("seed", (e.get("config") or {}).get("seed")))
        by_controller.setdefault(factor_value(e, controller), {}).setdefault(key, e["result"])
    names = list(by_controller)
    out = []
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            shared = [k for k in by_controller[a] if k in by_controller[b]]
            for metric in metrics:
                get = PAIRED_METRICS[metric][1]
                pairs = [(get(by_controller[a][k]), get(by_controller[b][k])) for k in shared]
                pairs = [(float(x), float(y)) for x, y in pairs
                         if x is not None and y is not None
                         and np.isfinite(float(x)) and np.isfinite(float(y))]
                n = len(pairs)
                xa = np.array([p[0] for p in pairs])
                xb = np.array([p[1] for p in pairs])
                diff = xb - xa
                mean = _mean(diff)
                if n >= 2:
                    half = float(t_quantile(0.975, n - 1) * diff.std(ddof=1) / np.sqrt(n))
                    low, high = mean - half, mean + half
                else:
                    low = high = float("nan")
                out.append(PairedDifference(str(a), str(b), metric, n, _mean(xa), _mean(xb),
                                            mean, low, high))
    return out
