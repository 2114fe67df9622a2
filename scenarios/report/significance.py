"""Whether a swept factor changes the outcome beyond chance, with the episodes' pairing kept.

The episodes of one session (a subject with a seed: its calibration, practice and sEMG
noise) are paired, not independent: a sweep's ``seed_by`` gives every level of a factor
the same sessions. A chi-square test on the levels x outcomes table treats every episode
as an independent draw, and with a few sessions it finds "effects" that are the sessions'.
Here each factor is tested by permutation of Pearson's chi-square of that table,
permuting only what the design lets vary:

- a factor whose level changes within a session (the object, the controller): its levels
  are shuffled among the episodes of each session, so every session keeps its episodes
  and its outcomes;
- a factor constant within every session (the subject): its levels are shuffled among
  whole sessions.

The p-value is ``(1 + #{chi2* >= chi2}) / (1 + B)`` over ``B`` = :data:`PERMUTATIONS`
shuffles (an exact test's Monte Carlo estimate, never 0). Holm's step-down procedure adjusts
the p-values for the number of factors tested; a factor is significant when its adjusted
p-value is below :data:`ALPHA`. The size of the largest effect is the difference of its
outcome's rate between its two extreme levels, with a 95 % interval from resampling whole
sessions (:data:`RESAMPLES` cluster-bootstrap resamples, percentile interval; none with
fewer than :data:`MIN_SESSIONS` sessions). Every draw
comes from a generator seeded with :data:`SEED`, so a store's report is the same each time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from scenarios.outcomes import row_outcome
from scenarios.report import factors as FA

#: Shuffles of each permutation test.
PERMUTATIONS = 4000
#: Session resamples of the effect's interval.
RESAMPLES = 4000
#: Significance level, after Holm's correction.
ALPHA = 0.05
#: Seed of the shuffles and resamples.
SEED = 0
#: Fewest sessions whose resampling gives an interval (with fewer, a cluster bootstrap
#: has too few distinct resamples to say anything).
MIN_SESSIONS = 5


def session_index(episodes: Sequence[Mapping[str, Any]]) -> np.ndarray:
    """The session of each episode (a subject with a seed) as 0..S-1, shape (n_episodes,)."""
    keys = [(e["result"].get("subject_id"), e["result"].get("seed", e["config"].get("seed")))
            for e in episodes]
    index = {k: i for i, k in enumerate(dict.fromkeys(map(repr, keys)))}
    return np.array([index[repr(k)] for k in keys], dtype=np.int64)


def _codes(values: Sequence[Any]) -> np.ndarray:
    index = {k: i for i, k in enumerate(dict.fromkeys(values))}
    return np.array([index[v] for v in values], dtype=np.int64)


def chi2_statistics(levels: np.ndarray, outcomes: np.ndarray) -> np.ndarray:
    """Pearson's chi-square of the levels x outcomes table of each row of ``levels``.

    Parameters
    ----------
    levels : ndarray of int, shape (n_tables, n_episodes)
        Level codes 0..r-1; every row a permutation of the same codes (the margins equal).
    outcomes : ndarray of int, shape (n_episodes,)
        Outcome codes 0..c-1.

    Returns
    -------
    ndarray, shape (n_tables,)
    """
    n_tables, n = levels.shape
    r, c = int(levels.max()) + 1, int(outcomes.max()) + 1
    flat = (levels * c + outcomes[None, :] + (np.arange(n_tables) * r * c)[:, None]).ravel()
    counts = np.bincount(flat, minlength=n_tables * r * c).reshape(n_tables, r, c)
    expected = np.outer(np.bincount(levels[0], minlength=r), np.bincount(outcomes, minlength=c))
    expected = expected / n
    used = expected > 0
    return (((counts - expected) ** 2)[:, used] / expected[used]).sum(axis=1)


def shuffled_levels(levels: np.ndarray, sessions: np.ndarray, n: int,
                    rng: np.random.Generator) -> np.ndarray:
    """``n`` shuffles of ``levels`` that keep the pairing (module docstring).

    Parameters
    ----------
    levels, sessions : ndarray of int, shape (n_episodes,)
        Level and session codes.
    n : int
        Shuffles.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray of int, shape (n, n_episodes)
    """
    n_sessions = int(sessions.max()) + 1
    first = np.full(n_sessions, -1)
    for i, s in enumerate(sessions):
        first[s] = levels[i] if first[s] < 0 else first[s]
    if np.all(levels == first[sessions]):  # constant within sessions: shuffle whole sessions
        order = np.argsort(rng.random((n, n_sessions)), axis=1)
        return first[order][:, sessions]
    by_session = np.argsort(sessions, kind="stable")
    order = np.argsort(sessions[None, :] * 2.0 + rng.random((n, sessions.size)), axis=1)
    out = np.empty((n, sessions.size), dtype=levels.dtype)
    out[:, by_session] = levels[order]
    return out


def permutation_p(episodes: Sequence[Mapping[str, Any]], factor: str,
                  rng: np.random.Generator, n_permutations: int = PERMUTATIONS,
                  sessions: np.ndarray | None = None) -> float:
    """The permutation p-value of ``factor``'s levels x outcomes chi-square (module docstring).

    ``sessions`` is :func:`session_index` of ``episodes``, when the caller has it already.
    """
    levels = _codes([FA.level_key(e, factor) for e in episodes])
    outcomes = _codes([row_outcome(e["result"]) for e in episodes])
    if levels.max() == 0 or outcomes.max() == 0:
        return 1.0
    observed = chi2_statistics(levels[None, :], outcomes)[0]
    sessions = session_index(episodes) if sessions is None else sessions
    shuffled = chi2_statistics(shuffled_levels(levels, sessions, n_permutations, rng), outcomes)
    return float((1 + np.count_nonzero(shuffled >= observed * (1 - 1e-9))) /
                 (1 + n_permutations))


def holm(p_values: Sequence[float]) -> np.ndarray:
    """Holm's step-down adjustment of ``m`` p-values: the k-th smallest times ``m - k + 1``,
    made non-decreasing in that order, at most 1; returned in the given order."""
    p = np.asarray(p_values, dtype=float)
    order = np.argsort(p, kind="stable")
    scaled = np.minimum(1.0, p[order] * (p.size - np.arange(p.size)))
    adjusted = np.empty_like(p)
    adjusted[order] = np.maximum.accumulate(scaled)
    return adjusted


def rate_difference_interval(episodes: Sequence[Mapping[str, Any]], factor: str,
                             levels: tuple[Any, Any], outcome: str,
                             rng: np.random.Generator) -> tuple[float, float]:
    """95 % interval of ``rate(outcome | levels[0]) - rate(outcome | levels[1])``, resampling
    whole sessions (:data:`RESAMPLES` times; percentile interval).

    Returns ``(nan, nan)`` when too few resamples hold both levels.
    """
    sessions = session_index(episodes)
    n_sessions = int(sessions.max()) + 1
    keys = [FA.level_key(e, factor) for e in episodes]
    hit = np.array([row_outcome(e["result"]) == outcome for e in episodes], dtype=float)
    weights = rng.multinomial(n_sessions, np.full(n_sessions, 1.0 / n_sessions), size=RESAMPLES)
    rates = []
    for level in levels:
        mine = np.array([k == level for k in keys], dtype=float)
        n = weights @ np.bincount(sessions, weights=mine, minlength=n_sessions)
        k = weights @ np.bincount(sessions, weights=mine * hit, minlength=n_sessions)
        with np.errstate(invalid="ignore", divide="ignore"):
            rates.append(k / n)
    difference = rates[0] - rates[1]
    difference = difference[np.isfinite(difference)]
    if difference.size < RESAMPLES // 2:
        return float("nan"), float("nan")
    low, high = np.percentile(difference, [2.5, 97.5])
    return float(low), float(high)


def seeded() -> np.random.Generator:
    """The generator of a report's tests and intervals (:data:`SEED`)."""
    return np.random.default_rng(SEED)

