"""What a sweep found: the swept factor that changes the grasp outcome most, from the numbers.

Every episode has one of four outcomes (:data:`scenarios.outcomes.OUTCOMES`). For each
swept factor, :func:`factor_effects` counts the outcomes at each of its levels (over every
other factor) and measures how strongly the level and the outcome are associated with
Cramér's V of that levels x outcomes table:

    V = sqrt(chi2 / (n (min(r, c) - 1)))

with ``chi2`` Pearson's statistic of independence, ``n`` episodes, ``r`` levels and ``c``
outcomes that occur. V is 0 when every level has the same outcome rates and 1 when the
level decides the outcome; unlike the spread of one rate it uses all four outcomes, and
unlike chi2 itself it compares factors with different numbers of levels. Factors are
ranked by V (ties: the larger spread of one outcome's rate, then the sweep's order). The
chi-square p-value treats every episode as independent and is not reported as a finding:
whether an effect is beyond chance is a permutation test that keeps each session's
episodes together, Holm-adjusted over the factors (:mod:`scenarios.report.significance`).
In a full grid the factors are balanced, so each one's rates average over the same
mix of the others; in an unbalanced set of episodes they are marginal rates.

:func:`findings_sentence` turns the ranking into one sentence; :func:`summary_section`
is the report's first section.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from scenarios.outcomes import OUTCOMES, row_outcome
from scenarios.report import factors as FA
from scenarios.report import figures as F
from scenarios.report import significance as SG
from scenarios.report import summaries as SU
from scenarios.report.html import Section, esc, note, side_by_side, svg_img, table
from scenarios.report.sections import ReportContext
from scenarios.stats import chi2_sf, wilson_interval

TITLE = "1. What the sweep found"
#: Outcome names as words.
OUTCOME_WORDS = {"held": "held", "not_lifted": "not lifted", "dropped": "dropped",
                 "crushed": "crushed"}


@dataclass(frozen=True)
class LevelOutcomes:
    """Outcome counts of the episodes at one level of a factor.

    Attributes
    ----------
    level : Any
        The factor's value.
    n : int
        Episodes at this level.
    counts : dict of str to int
        Episodes per outcome of :data:`scenarios.outcomes.OUTCOMES`.
    """

    level: Any
    n: int
    counts: dict[str, int]

    def rate(self, outcome: str) -> float:
        """Fraction of the level's episodes with ``outcome``."""
        return self.counts[outcome] / self.n

    def interval(self, outcome: str) -> tuple[float, float]:
        """95 % Wilson interval of :meth:`rate`."""
        return wilson_interval(self.counts[outcome], self.n)


@dataclass(frozen=True)
class FactorEffect:
    """How much one swept factor changes the outcome.

    Attributes
    ----------
    factor : str
        Config path of the factor.
    levels : list of LevelOutcomes
        Its levels in the report's order (numbers ascending, names in store order).
    chi2 : float
        Pearson's chi-square of the levels x outcomes table (outcomes that occur only).
    dof : int
        Its degrees of freedom, ``(r - 1)(c - 1)``.
    cramers_v : float
        Cramér's V, 0..1.
    p_value : float
        Chi-square p-value (``nan`` when ``dof`` is 0).
    outcome : str
        The outcome whose rate differs most between levels.
    high, low : LevelOutcomes
        The levels with the highest and the lowest rate of ``outcome`` (first on ties).
    aliases : tuple of str
        Other swept factors that split the episodes exactly as this one does (their
        effects cannot be told apart from this one's).
    p_permutation : float
        Permutation p-value of ``chi2`` with the sessions kept together
        (:func:`scenarios.report.significance.permutation_p`; ``nan`` until
        :func:`judge_effects` ran).
    p_holm : float
        ``p_permutation`` adjusted by Holm's procedure over the factors tested.
    """

    factor: str
    levels: list[LevelOutcomes]
    chi2: float
    dof: int
    cramers_v: float
    p_value: float
    outcome: str
    high: LevelOutcomes
    low: LevelOutcomes
    aliases: tuple[str, ...] = ()
    p_permutation: float = float("nan")
    p_holm: float = float("nan")

    @property
    def spread(self) -> float:
        """``high.rate(outcome) - low.rate(outcome)``."""
        return self.high.rate(self.outcome) - self.low.rate(self.outcome)

    @property
    def name(self) -> str:
        """Short name of the factor, with its aliases: ``"object (same split as mass (kg))"``."""
        name = FA.factor_name(self.factor)
        if self.aliases:
            name += f" (same split as {', '.join(FA.factor_name(a) for a in self.aliases)})"
        return name


def level_outcomes(episodes: Sequence[Mapping[str, Any]], factor: str) -> list[LevelOutcomes]:
    """Outcome counts at each level of ``factor`` (levels in
    :func:`~scenarios.report.factors.levels` order)."""
    by_level: dict[Any, dict[str, int]] = {}
    for e in episodes:
        counts = by_level.setdefault(FA.level_key(e, factor), dict.fromkeys(OUTCOMES, 0))
        counts[row_outcome(e["result"])] += 1
    return [LevelOutcomes(level, sum(by_level[level].values()), by_level[level])
            for level in FA.levels(episodes, factor)]


def cramers_v(counts: np.ndarray) -> tuple[float, float, int]:
    """Cramér's V, chi-square and degrees of freedom of a contingency table.

    Rows and columns that sum to zero are dropped first; a table left with fewer than two
    rows or two columns shows no association: ``(0.0, 0.0, 0)``.

    Parameters
    ----------
    counts : ndarray of int, shape (n_levels, n_outcomes)
    """
    table = np.asarray(counts, dtype=float)
    table = table[table.sum(axis=1) > 0][:, table.sum(axis=0) > 0]
    r, c = table.shape
    if r < 2 or c < 2:
        return 0.0, 0.0, 0
    n = table.sum()
    expected = np.outer(table.sum(axis=1), table.sum(axis=0)) / n
    chi2 = float(((table - expected) ** 2 / expected).sum())
    chi2 = 0.0 if chi2 < 1e-9 else chi2  # equal proportions up to round-off: no association
    return float(np.sqrt(chi2 / (n * (min(r, c) - 1)))), chi2, (r - 1) * (c - 1)


def _widest_outcome(levels: Sequence[LevelOutcomes]
                    ) -> tuple[str, LevelOutcomes, LevelOutcomes]:
    """The outcome whose rate spreads most over ``levels`` and its highest and lowest level."""
    best = None
    for outcome in OUTCOMES:
        rates = [lv.rate(outcome) for lv in levels]
        high, low = int(np.argmax(rates)), int(np.argmin(rates))
        spread = rates[high] - rates[low]
        if best is None or spread > best[0]:
            best = (spread, outcome, levels[high], levels[low])
    return best[1], best[2], best[3]


def factor_effects(episodes: Sequence[Mapping[str, Any]],
                   factors: Sequence[str]) -> list[FactorEffect]:
    """The swept factors ranked by how much they change the outcome (Cramér's V, descending).

    Parameters
    ----------
    episodes : sequence of dict
        ``ok`` episode rows.
    factors : sequence of str
        Swept factors (:func:`scenarios.report.factors.swept_factors`); a factor with one
        level among ``episodes`` is skipped.

    Returns
    -------
    list of FactorEffect
        One per factor that splits the episodes differently from every factor ranked
        before it (a factor splitting them identically is an alias of that one).
    """
    partitions: dict[tuple, str] = {}
    aliases: dict[str, list[str]] = {}
    effects = []
    for factor in factors:
        keys = [FA.level_key(e, factor) for e in episodes]
        index = {k: i for i, k in enumerate(dict.fromkeys(keys))}
        if len(index) < 2:
            continue
        partition = tuple(index[k] for k in keys)
        if partition in partitions:
            aliases[partitions[partition]].append(factor)
            continue
        partitions[partition] = factor
        aliases[factor] = []
        levels = level_outcomes(episodes, factor)
        v, chi2, dof = cramers_v(np.array([[lv.counts[o] for o in OUTCOMES]
                                           for lv in levels]))
        outcome, high, low = _widest_outcome(levels)
        effects.append(FactorEffect(factor, levels, chi2, dof, v,
                                    chi2_sf(chi2, dof) if dof else float("nan"),
                                    outcome, high, low))
    effects = [replace(e, aliases=tuple(aliases[e.factor])) for e in effects]
    order = {f: i for i, f in enumerate(factors)}
    return sorted(effects, key=lambda e: (-round(e.cramers_v, 12), -round(e.spread, 12),
                                          order[e.factor]))


def judge_effects(episodes: Sequence[Mapping[str, Any]],
                   effects: Sequence[FactorEffect]) -> list[FactorEffect]:
    """``effects`` with their permutation p-values, Holm-adjusted over all of them.

    Each factor is tested by :func:`scenarios.report.significance.permutation_p`, which keeps
    each session's episodes together; the shuffles come from
    :func:`~scenarios.report.significance.seeded`, so a store's report is the same each time.
    """
    if not effects:
        return []
    rng, sessions = SG.seeded(), SG.session_index(episodes)  # the sessions once, every factor
    raw = [SG.permutation_p(episodes, e.factor, rng, sessions=sessions) for e in effects]
    return [replace(e, p_permutation=p, p_holm=float(h))
            for e, p, h in zip(effects, raw, SG.holm(raw), strict=True)]


def _p_text(p: float) -> str:
    return "p < 0.001" if p < 1e-3 else f"p = {p:.2g}"


def _noise_sentence(episodes: Sequence[Mapping[str, Any]],
                    effects: Sequence[FactorEffect]) -> str:
    """No factor significant: say so, then the largest effect with its interval."""
    top = effects[0]
    sessions = int(SG.session_index(episodes).max()) + 1
    if sessions < SG.MIN_SESSIONS:
        interval = f"no interval: {sessions} sessions are too few to resample"
    else:
        low, high = SG.rate_difference_interval(episodes, top.factor,
                                                (top.high.level, top.low.level), top.outcome,
                                                SG.seeded())
        interval = ("no interval: too few resamples hold both levels" if np.isnan(low) else
                    f"95 % interval {100 * low:+.0f} to {100 * high:+.0f} points, resampling "
                    "sessions")
    return (f"No swept factor changes the outcome beyond chance: none of the {len(effects)} "
            f"tested reaches p < {SG.ALPHA:g} after Holm's correction (permutation tests "
            f"that keep each of the {sessions} sessions' episodes together). The largest "
            f"effect is that of {top.name} (Cramér's V {top.cramers_v:.2f}, "
            f"{_p_text(top.p_holm)} adjusted): {OUTCOME_WORDS[top.outcome]} in "
            f"{percent(top.high, top.outcome)} of the {top.high.n} episodes at "
            f"{level_phrase(top.factor, top.high.level)} and in "
            f"{percent(top.low, top.outcome)} of the {top.low.n} at "
            f"{level_phrase(top.factor, top.low.level)}, a difference of "
            f"{100 * top.spread:.0f} points ({interval}).")


def held_counts(episodes: Sequence[Mapping[str, Any]], x: str, series: str | None
                ) -> list[tuple[str, list[tuple[int, int]]]]:
    """``(held, episodes)`` at each level of ``x``, per level of ``series`` (one unlabelled
    series when None): the data of :func:`scenarios.report.figures.held_rate_figure`."""
    x_levels = FA.levels(episodes, x)
    s_levels = FA.levels(episodes, series) if series else [None]
    cells: dict[tuple[Any, Any], list[int]] = {}
    for e in episodes:
        key = (FA.level_key(e, x), FA.level_key(e, series) if series else None)
        cell = cells.setdefault(key, [0, 0])
        cell[0] += row_outcome(e["result"]) == "held"
        cell[1] += 1
    return [(FA.level_text(s) if series else "",
             [tuple(cells.get((xv, s), (0, 0))) for xv in x_levels]) for s in s_levels]


def percent(level: LevelOutcomes, outcome: str) -> str:
    """``"94 % (74–99 %)"``: the rate of ``outcome`` at ``level`` with its Wilson interval."""
    low, high = level.interval(outcome)
    return f"{100 * level.rate(outcome):.0f} % ({100 * low:.0f}–{100 * high:.0f} %)"


def level_phrase(factor: str, level: Any) -> str:
    """``"mass (kg) = 0.2"``."""
    return f"{FA.factor_name(factor)} = {FA.level_text(level)}"


def overall_counts(episodes: Sequence[Mapping[str, Any]]) -> str:
    """``"54 episodes: 30 held, 20 dropped, 4 crushed (none not lifted)"``."""
    outcomes = [row_outcome(e["result"]) for e in episodes]
    seen = [f"{outcomes.count(o)} {OUTCOME_WORDS[o]}" for o in OUTCOMES if o in outcomes]
    none = [OUTCOME_WORDS[o] for o in OUTCOMES if o not in outcomes]
    missing = " or ".join([", ".join(none[:-1]), none[-1]] if len(none) > 1 else none)
    return (f"{len(outcomes)} episode{'s' if len(outcomes) != 1 else ''}: {', '.join(seen)}"
            + (f" (none {missing})" if none else ""))


def session_text(episodes: Sequence[Mapping[str, Any]]) -> str:
    """``"3 subjects in 3 sessions"``: how many independent draws the episodes rest on.

    A session is a subject with a seed (its calibration, practice and sEMG noise); the
    episodes of one session are paired, not independent, so an interval over them says
    little about other people.
    """
    pairs = {(e["result"].get("subject_id"), e["result"].get("seed", e["config"].get("seed")))
             for e in episodes}
    subjects = {p[0] for p in pairs}
    text = (f"{len(subjects)} subject{'s' if len(subjects) != 1 else ''} in {len(pairs)} "
            f"session{'s' if len(pairs) != 1 else ''}")
    if len(pairs) < 3:
        text += " (the intervals describe these sessions, not a population)"
    return text


def findings_sentence(episodes: Sequence[Mapping[str, Any]],
                      effects: Sequence[FactorEffect]) -> str:
    """One sentence: the factor that changes the outcome most and by how much, when any
    factor's effect is beyond chance (Holm-adjusted permutation p below
    :data:`scenarios.report.significance.ALPHA`); otherwise that none is, then the largest
    effect with the interval of its rate difference.

    Parameters
    ----------
    episodes : sequence of dict
        ``ok`` episode rows (at least one).
    effects : sequence of FactorEffect
        :func:`factor_effects` of the episodes (tested here unless :func:`judge_effects`
        already ran).
    """
    n = len(episodes)
    if not effects:
        whole = LevelOutcomes(None, n, {o: sum(row_outcome(e["result"]) == o
                                               for e in episodes) for o in OUTCOMES})
        outcome = max(OUTCOMES, key=lambda o: whole.counts[o])
        if n == 1:
            return (f"The store holds one episode ({OUTCOME_WORDS[outcome]}) and nothing "
                    "varies: there is no factor to compare.")
        return (f"Nothing varies between these {n} episodes but the seed (every factor has "
                f"one level): {OUTCOME_WORDS[outcome]} in {whole.counts[outcome]} of {n}, "
                f"{percent(whole, outcome)}; there is no factor to compare.")
    if effects[0].cramers_v == 0.0:
        names = ", ".join(e.name for e in effects)
        return (f"No swept factor changes the outcome: every level of {names} has the same "
                f"outcome rates ({overall_counts(episodes)}).")
    if any(np.isnan(e.p_holm) for e in effects):
        effects = judge_effects(episodes, effects)
    found = [e for e in effects if e.p_holm < SG.ALPHA and e.cramers_v > 0.0]
    if not found:
        return _noise_sentence(episodes, effects)
    top = found[0]
    most = "most" if top is effects[0] else "most beyond chance"
    sentence = (f"Of the swept factors, {top.name} changes the outcome {most} (Cramér's V "
                f"{top.cramers_v:.2f}; permutation {_p_text(top.p_permutation)} with the "
                f"sessions kept together, {_p_text(top.p_holm)} after Holm's correction over "
                f"{len(effects)} factors): {OUTCOME_WORDS[top.outcome]} in "
                f"{percent(top.high, top.outcome)} of the {top.high.n} episodes at "
                f"{level_phrase(top.factor, top.high.level)} and in "
                f"{percent(top.low, top.outcome)} of the {top.low.n} at "
                f"{level_phrase(top.factor, top.low.level)}")
    if len(found) > 1:
        sentence += f"; next comes {found[1].name} (V {found[1].cramers_v:.2f})"
    return sentence + "."


def rate_cells(level: LevelOutcomes, outcomes: Sequence[str]) -> list[str]:
    """Table cells of ``outcomes`` at one level: rates with intervals, or for one episode
    its outcome in its column and a dash elsewhere (a rate of one episode says nothing more)."""
    if level.n == 1:
        return [OUTCOME_WORDS[o] if level.counts[o] else "–" for o in outcomes]
    return [percent(level, o) for o in outcomes]


def _rates_table(effects: Sequence[FactorEffect], outcomes: Sequence[str]) -> str:
    rows = []
    for e in effects:
        if e.cramers_v == 0.0:
            continue
        for i, lv in enumerate(e.levels):
            rows.append([f"{e.name}, V {e.cramers_v:.2f}" if i == 0 else "",
                         FA.level_text(lv.level), lv.n, *rate_cells(lv, outcomes)])
    return table(["factor", "level", "n", *(f"{OUTCOME_WORDS[o]} % (95 % CI)" for o in outcomes)],
                 rows, "Outcome rates at each level of each factor that changes them "
                 "(strongest first)", text_columns=2)


def _median_iqr(values: Sequence[float], spec: str) -> str:
    """``"1.6 [1.5–2.1]"``: the median and the interquartile range (``–`` when empty)."""
    if not values:
        return "–"
    q1, q2, q3 = np.percentile(np.asarray(values, dtype=float), [25, 50, 75])
    return f"{q2:{spec}} [{q1:{spec}}–{q3:{spec}}]"


def trial_rows(episodes: Sequence[Mapping[str, Any]], factor: str | None
               ) -> list[list[Any]]:
    """Per level of ``factor`` (all episodes when None): n, held with its interval, time to
    lift, attempts and safety margin of the trials the user paced."""
    groups: dict[Any, list[Mapping[str, Any]]] = {}
    for e in episodes:
        groups.setdefault(FA.level_key(e, factor) if factor else None, []).append(e)
    levels = FA.levels(episodes, factor) if factor else [None]
    rows = []
    for level in levels:
        mine = [e["result"] for e in groups.get(level, [])]
        held = sum(row_outcome(r) == "held" for r in mine)
        lv = LevelOutcomes(level, len(mine), {o: sum(row_outcome(r) == o for r in mine)
                                              for o in OUTCOMES})
        attempts = [r["attempts"] for r in mine if r.get("attempts") is not None]
        rows.append([FA.level_text(level) if factor else "all", len(mine),
                     percent(lv, "held") if mine else "–",
                     _median_iqr([r["time_to_lift_s"] for r in mine
                                  if r.get("time_to_lift_s") is not None], ".2f"),
                     f"{np.mean(attempts):.2f}" if attempts else "–",
                     _median_iqr([r["safety_margin_pct"] for r in mine
                                  if r.get("safety_margin_pct") is not None], ".0f"),
                     held])
    return rows


def _trial_table(episodes: Sequence[Mapping[str, Any]], factors: Sequence[str]) -> str:
    """Success, time to lift, attempts and safety margin by factor (trials the user paced)."""
    paced = [e for e in episodes if e["result"].get("attempts") is not None]
    if not paced:
        return ""
    rows = []
    for factor in [*factors, None] if factors else [None]:
        if factor is not None and len(FA.levels(paced, factor)) < 2:
            continue
        for i, row in enumerate(trial_rows(paced, factor)):
            rows.append([(FA.factor_name(factor) if factor else "all trials") if i == 0
                         else "", *row[:-1]])
    return table(["factor", "level", "n", "held % (95 % CI)", "time to lift (s)",
                  "attempts", "safety margin (%)"], rows,
                 "Trials the user paced, by factor: held, time from the first contact to "
                 "a secure lift and safety margin as median [interquartile range], lifts "
                 "started per trial (mean)", text_columns=2)


def _no_episode_sentence(context: ReportContext) -> str:
    rows, split = context.rows, context.split
    where = f"sweep {context.sweep}" if context.sweep else "the store"
    if not rows:
        return (f"{where[0].upper()}{where[1:]} holds no rows: nothing has run, so there is "
                "nothing to summarize.")
    if len(split.failed) == len(rows):
        return (f"All {len(rows)} rows of {where} failed, so there is no outcome to "
                "summarize: their errors are listed under Failed scenarios.")
    return (f"{where[0].upper()}{where[1:]} holds no episode rows ({len(split.reproduction)} "
            f"reproduction, {len(split.other)} other, {len(split.failed)} failed): there is "
            "no grasp outcome to summarize.")


def summary_section(context: ReportContext) -> Section:
    """The report's first section: the finding in one sentence, the outcome rates by factor,
    the paired controller differences (forest plot) and the held rate by the strongest
    factors (the paper figure)."""
    episodes = context.split.episodes
    if not episodes:
        return Section("summary", TITLE,
                       f'<p class="finding">{esc(_no_episode_sentence(context))}</p>', True)
    factors = list(context.factors)
    effects = judge_effects(episodes, factor_effects(episodes, factors))
    parts = [f'<p class="finding">{esc(findings_sentence(episodes, effects))}</p>']
    if not effects:
        parts.append(_trial_table(episodes, []))
        return Section("summary", TITLE, "\n".join(parts))
    outcomes = [o for o in OUTCOMES
                if any(lv.counts[o] for e in effects for lv in e.levels)]
    unchanged = [e.name for e in effects if e.cramers_v == 0.0]
    parts.append(note(
        f"{overall_counts(episodes)}, from {session_text(episodes)}. Factors ranked by "
        "Cramér's V of their levels x outcomes table (0: the same outcome rates at every "
        "level; 1: the level decides the outcome); rates with 95 % Wilson intervals, over "
        "every other factor. An effect is beyond chance when its permutation test (levels "
        "shuffled within sessions, or among whole sessions for a factor constant within "
        f"them) gives p < {SG.ALPHA:g} after Holm's correction over the factors tested."
        + (f" Same rates at every level: {', '.join(unchanged)}." if unchanged else "")))
    parts.append(_trial_table(episodes, [e.factor for e in effects]
                              + [f for f in factors if f not in {e.factor for e in effects}]))
    parts.append(_rates_table(effects, outcomes))
    figures = []
    if FA.CONTROLLER_FACTOR in factors:
        diffs = [d for d in SU.paired_differences(episodes, factors) if d.n_pairs]
        if diffs:
            figures.append(svg_img(F.svg_bytes(F.forest_figure(diffs)),
                                   "forest plot of paired controller differences"))
    ranked = [e.factor for e in effects]
    x = ranked[0]
    series = (FA.CONTROLLER_FACTOR if FA.CONTROLLER_FACTOR in ranked and x != FA.CONTROLLER_FACTOR
              else ranked[1] if len(ranked) > 1 else None)
    fig = F.held_rate_figure(FA.factor_name(x), [FA.level_text(v) for v in FA.levels(episodes, x)],
                             held_counts(episodes, x, series),
                             FA.factor_name(series) if series else "")
    figures.append(svg_img(F.svg_bytes(fig), f"held rate by {FA.factor_name(x)}"))
    parts.append(side_by_side(figures))
    if FA.CONTROLLER_FACTOR in factors:
        parts.append(note("Forest plot: each controller against each other on the same "
                          "scenarios (every other factor and the seed equal), mean paired "
                          "difference B − A with its 95 % t interval; the numbers are in "
                          "section 3."))
    return Section("summary", TITLE, "\n".join(parts))
