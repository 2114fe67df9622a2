"""The report does not call noise a finding: permutation tests that keep the sessions
together, Holm's correction, and the largest effect with its interval (issue 37, item 3).

Episode rows are built here with the outcome chosen by the test, so whether a factor
matters, and how many independent sessions there are, is known by construction.
"""

from __future__ import annotations

import itertools
import re

import numpy as np
import pytest
from scipy import stats

from scenarios.report import factors as FA
from scenarios.report import significance as SG
from scenarios.report.findings import factor_effects, findings_sentence, judge_effects


def row(subject: int, seed: int, mass: float, controller: str, friction: float,
        outcome: str) -> dict:
    """An ``ok`` episode row of the can with these factors and ``outcome``."""
    result = {"subject_id": subject, "seed": seed, "controller": controller,
              "estimator": "oracle", "mode": "one_step", "object_name": "can",
              "object_mass_kg": mass, "object_friction": friction, "outcome": outcome}
    return {"kind": "episode", "status": "ok", "result": result,
            "config": {"seed": seed, "subject": {"subject_id": subject},
                       "object": {"name": "can", "mass_kg": mass, "friction": friction},
                       "controller": {"kind": controller}}}


def test_holm_matches_its_closed_form():
    # sorted 0.01, 0.03, 0.04 times 3, 2, 1: 0.03, 0.06, 0.04 -> made non-decreasing
    assert SG.holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    assert SG.holm([0.5, 0.9]) == pytest.approx([1.0, 1.0])


def test_the_statistic_is_pearsons_chi_square():
    rng = np.random.default_rng(1)
    levels, outcomes = rng.integers(0, 3, 60), rng.integers(0, 2, 60)
    table = np.array([[np.sum((levels == i) & (outcomes == j)) for j in range(2)]
                      for i in range(3)])
    chi2 = stats.chi2_contingency(table, correction=False)[0]
    assert SG.chi2_statistics(levels[None, :], outcomes)[0] == pytest.approx(chi2, rel=1e-12)


def test_shuffles_keep_each_session_whole():
    rng = np.random.default_rng(2)
    sessions = np.repeat(np.arange(4), 5)
    within = np.tile([0, 0, 1, 1, 2], 4)  # varies within every session
    shuffled = SG.shuffled_levels(within, sessions, 200, rng)
    for s in range(4):
        counts = [np.bincount(r[sessions == s], minlength=3) for r in shuffled]
        assert all((c == np.bincount(within[sessions == s], minlength=3)).all() for c in counts)
    assert len({tuple(r) for r in shuffled}) > 50  # and it does shuffle
    constant = np.repeat([0, 1, 1, 0], 5)  # one level per session (a subject)
    shuffled = SG.shuffled_levels(constant, sessions, 200, rng)
    assert all(len(set(r[sessions == s])) == 1 for r in shuffled for s in range(4))
    assert all(sorted(r[::5]) == [0, 0, 1, 1] for r in shuffled)


def test_two_subjects_that_differ_are_not_a_finding():
    """40 episodes, all held for subject 1 and all dropped for subject 2: chi-square's
    p is 1e-9, but there are two sessions, so no test that keeps them whole can tell the
    subject from the session."""
    rows = [row(s, 10 + s, m, c, 0.5, "held" if s == 1 else "dropped")
            for s in (1, 2) for m in (0.2, 0.4) for c in ("pid", "mpc") for _ in range(5)]
    effects = judge_effects(rows, factor_effects(rows, FA.swept_factors(rows)))
    subject = next(e for e in effects if e.factor == "subject.subject_id")
    assert subject.cramers_v == pytest.approx(1.0) and subject.p_value < 1e-8
    assert subject.p_permutation >= 0.5
    sentence = findings_sentence(rows, effects)
    assert sentence.startswith("No swept factor changes the outcome beyond chance: none of "
                               "the 3 tested reaches p < 0.05 after Holm's correction")
    assert "each of the 2 sessions' episodes together" in sentence
    assert "The largest effect is that of subject (Cramér's V 1.00" in sentence
    assert "a difference of 100 points (no interval: 2 sessions are too few to resample)" \
        in sentence


def test_noise_is_said_to_be_noise_and_the_largest_effect_gets_its_interval():
    rng = np.random.default_rng(3)
    rows = [row(1, 100 + s, m, c, f, "held" if rng.random() < 0.6 else "dropped")
            for s in range(1, 7) for m, c, f in itertools.product((0.2, 0.4, 0.6),
                                                                  ("pid", "mpc"), (0.3, 0.8))]
    effects = judge_effects(rows, factor_effects(rows, FA.swept_factors(rows)))
    assert all(e.p_holm >= SG.ALPHA for e in effects)
    sentence = findings_sentence(rows, effects)
    assert sentence.startswith("No swept factor changes the outcome beyond chance")
    top = effects[0]
    low, high = SG.rate_difference_interval(rows, top.factor, (top.high.level, top.low.level),
                                            top.outcome, SG.seeded())
    assert low < top.spread < high  # the interval holds the observed difference
    match = re.search(r"95 % interval ([+-]\d+) to ([+-]\d+) points", sentence)
    assert match and (int(match[1]), int(match[2])) == (round(100 * low), round(100 * high))


def test_a_factor_that_decides_within_every_session_is_a_finding():
    rows = [row(s, 200 + s, m, c, 0.5, "held" if m < 0.3 else "dropped")
            for s in range(1, 7) for m in (0.2, 0.4) for c in ("pid", "mpc")]
    effects = judge_effects(rows, factor_effects(rows, FA.swept_factors(rows)))
    mass = next(e for e in effects if e.factor == "object.mass_kg")
    # six sessions, each of two 0.2 kg and two 0.4 kg episodes: p = 2 (1/6)^6 exactly
    assert mass.p_permutation == pytest.approx(1 / (1 + SG.PERMUTATIONS), rel=1e-9)
    assert findings_sentence(rows, effects).startswith(
        "Of the swept factors, mass (kg) changes the outcome most (Cramér's V 1.00; "
        "permutation p < 0.001 with the sessions kept together")


def test_the_same_store_gives_the_same_sentence():
    rows = [row(s, 300 + s, m, "pid", 0.5, "held" if (s + int(10 * m)) % 3 else "dropped")
            for s in range(1, 5) for m in (0.2, 0.4, 0.6)]
    effects = factor_effects(rows, FA.swept_factors(rows))
    assert findings_sentence(rows, effects) == findings_sentence(rows, effects)
