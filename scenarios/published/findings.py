"""The published findings of the board, in order, each with its source, rule and protocol.

Each :class:`Finding` names what people showed (with its source and the published
figure), the rule its verdict follows (:mod:`scenarios.published.rules`; written in
docs/PUBLISHED.md before the full run), the conditions it runs (:mod:`.arms`) and how its
figure is read from the scenarios' rows (``judge``). Every figure is a mean or rate over
the board's subjects with its 95 % interval; effects are paired by subject (the same
seeds in both conditions).

The prosthesis runs under the board's clinical interface (``velocity`` on the
self-locking drive with the ``pattern`` decoder by default: what clinics fit); the intact
hand is the human-speed hand (estimator ``intact``, felt by touch).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.published.arms import Arm, BoardConfig, clinical, intact, rigid_objects
from scenarios.published.rules import (
    Band,
    Direction,
    Interval,
    Range,
    bootstrap_interval,
    combine,
    mean_with_interval,
    paired_differences,
    rate_with_interval,
)
from scenarios.runners.trial_outcome import margin_over_grip_pct

Rows = Sequence[Mapping[str, Any]]
Evidence = Mapping[str, Rows]
"""Each arm's successful scenario rows (result mappings with ``subject_id``)."""

MDC_BLOCKS = 6.5
"""Box and Blocks: the smallest change beyond one person's test-retest noise, blocks/min
(minimum detectable change; Resnik & Borgia 2012, n = 73 prosthesis users)."""
EGG_FORCES_N = (0.4, 0.56, 0.78, 1.1, 1.53, 2.14, 3.0, 4.2, 5.87, 8.22, 11.5)
"""The Virtual Eggs Test's 11 break forces as ``griploop eggs`` spaces them, N."""
SMOKE_EGG_FORCES_N = (2.14, 8.22)
RAVEH_BLOCKS = 16
"""Blocks of Raveh et al.'s modified Box and Blocks test in the dark."""


@dataclass(frozen=True)
class Judgement:
    """griploop's figure for a finding: the number, its 95 % interval, the verdict and
    what else the reader needs (``details``)."""

    figure: float | None
    ci95: Interval
    verdict: str
    details: dict[str, Any]


@dataclass(frozen=True)
class Finding:
    """One row of the board (module notes)."""

    id: str
    finding: str
    source: str
    published: str
    rule: str
    unit: str
    published_range: tuple[float, float]
    arms: Callable[[BoardConfig], dict[str, Arm]]
    judge: Callable[[Evidence, np.random.Generator], Judgement]


# ------------------------------------------------------------------ helpers
def by_subject(rows: Rows, key: str) -> dict[int, float | None]:
    """The mean of ``key`` per subject over an arm's rows (None where never measured)."""
    out: dict[int, list[float]] = {}
    for r in rows:
        out.setdefault(int(r["subject_id"]), [])
        if r.get(key) is not None:
            out[int(r["subject_id"])].append(float(r[key]))
    return {s: (float(np.mean(v)) if v else None) for s, v in out.items()}


def subject_rate(rows: Rows, k_key: str, n_key: str) -> dict[int, float | None]:
    """``sum k / sum n`` per subject (None where ``n`` is 0)."""
    k: dict[int, float] = {}
    n: dict[int, float] = {}
    for r in rows:
        s = int(r["subject_id"])
        k[s] = k.get(s, 0.0) + float(r[k_key])
        n[s] = n.get(s, 0.0) + float(r[n_key])
    return {s: (k[s] / n[s] if n[s] else None) for s in k}


def effect(a: Rows, b: Rows, key: str) -> dict[str, Any]:
    """The paired effect ``a - b`` of ``key`` over subjects: mean, interval, pairs."""
    diffs = paired_differences(by_subject(a, key), by_subject(b, key))
    mean, ci = mean_with_interval(diffs)
    return {"mean": mean, "ci95": ci, "pairs": len(diffs)}


def _range_row(values: dict[int, float | None], bounds: Range) -> Judgement:
    mean, ci = mean_with_interval(list(values.values()))
    return Judgement(mean, ci, bounds.verdict(mean, ci), {"subjects": len(values)})


# ------------------------------------------------------------ the findings
def _bbt_intact_arms(c: BoardConfig) -> dict[str, Arm]:
    return {"intact": Arm("transfers", {**intact(c), **_bbt_length(c)})}


def _bbt_length(c: BoardConfig) -> dict[str, Any]:
    return {"protocol.duration_s": 10.0} if c.smoke else {}


def _bbt_prosthesis_arms(c: BoardConfig, modes: Sequence[str] = ("none",)) -> dict[str, Arm]:
    return {f"prosthesis_{m}": Arm("transfers", {**clinical(c, user__feedback=m),
                                                  **_bbt_length(c)}) for m in modes}


def _judge_bbt_intact(ev: Evidence, rng: np.random.Generator) -> Judgement:
    return _range_row(by_subject(ev["intact"], "blocks_per_min"), Range(70.0, 95.0))


def _judge_bbt_prosthesis(ev: Evidence, rng: np.random.Generator) -> Judgement:
    return _range_row(by_subject(ev["prosthesis_none"], "blocks_per_min"), Range(12.0, 25.0))


def _judge_bbt_ratio(ev: Evidence, rng: np.random.Generator) -> Judgement:
    p = by_subject(ev["prosthesis_none"], "blocks_per_min")
    i = by_subject(ev["intact"], "blocks_per_min")
    pairs = np.array([(p[s], i[s]) for s in sorted(set(p) & set(i))
                      if p[s] is not None and i[s] is not None], dtype=float).reshape(-1, 2)

    def ratio(rows: np.ndarray) -> float:
        den = float(np.mean(rows[:, 1]))
        return float(np.mean(rows[:, 0]) / den) if den > 0 else float("nan")

    figure = ratio(pairs) if pairs.size else None
    ci = bootstrap_interval(ratio, pairs, rng) if pairs.size else None
    figure = None if figure is None or not np.isfinite(figure) else figure
    return Judgement(figure, ci, Range(0.0, 1.0 / 3.0).verdict(figure, ci),
                     {"pairs": int(pairs.shape[0])})


def _judge_bbt_feedback(ev: Evidence, rng: np.random.Generator) -> Judgement:
    effects = {m: effect(ev[f"prosthesis_{m}"], ev["prosthesis_none"], "blocks_per_min")
               for m in ("force_vibration", "slip_vibration")}
    band = Band(MDC_BLOCKS)
    verdict = combine([band.verdict(e["ci95"]) for e in effects.values()])
    largest = max(effects, key=lambda m: abs(effects[m]["mean"] or 0.0))
    return Judgement(effects[largest]["mean"], effects[largest]["ci95"], verdict,
                     {"largest": largest, "effects": effects})


def _dark_arms(c: BoardConfig) -> dict[str, Arm]:
    blocks = 2 if c.smoke else RAVEH_BLOCKS
    return {f"dark_{m}": Arm("transfers", {**clinical(c, user__feedback=m),
                                           "user.vision": False, "protocol.blocks": blocks})
            for m in ("none", "force_vibration")}


def _judge_dark(ev: Evidence, rng: np.random.Generator) -> Judgement:
    time = effect(ev["dark_force_vibration"], ev["dark_none"], "time_per_block_s")
    drops = effect(ev["dark_force_vibration"], ev["dark_none"], "blocks_dropped")
    lower = Direction(-1)
    verdict = combine([lower.verdict(time["ci95"]), lower.verdict(drops["ci95"])])
    return Judgement(time["mean"], time["ci95"], verdict,
                     {"time_per_block_s": time, "drops": drops,
                      "none_time_per_block_s": mean_with_interval(
                          list(by_subject(ev["dark_none"], "time_per_block_s").values()))[0]})


SLIP_MODES = ("none", "force_vibration", "slip_vibration")


def _slip_arms(c: BoardConfig) -> dict[str, Arm]:
    extra = {"protocol.trials": 1} if c.smoke else {}
    return {f"slip_{m}": Arm("slip_recovery", {**clinical(c, user__feedback=m),
                                               "protocol.perturbation": "opening", **extra})
            for m in SLIP_MODES}


def _judge_slip(ev: Evidence, rng: np.random.Generator) -> Judgement:
    rows = ev["slip_slip_vibration"]
    k = int(sum(r["recovered"] for r in rows))
    n = int(sum(r["n"] for r in rows))
    rate, ci = rate_with_interval(k, n)
    rates = {m: subject_rate(ev[f"slip_{m}"], "recovered", "n") for m in SLIP_MODES}
    over = {m: mean_with_interval(paired_differences(rates["slip_vibration"], rates[m]))
            for m in ("none", "force_vibration")}
    more = Direction(+1)
    verdict = combine([Range(0.95, 1.0).verdict(rate, ci),
                       *(more.verdict(ci_m) for _, ci_m in over.values())])
    pooled = {m: {"recovered": int(sum(r["recovered"] for r in ev[f"slip_{m}"])),
                  "n": int(sum(r["n"] for r in ev[f"slip_{m}"])),
                  "no_slip": int(sum(r.get("no_slip", 0) for r in ev[f"slip_{m}"]))}
              for m in SLIP_MODES}
    return Judgement(rate, ci, verdict,
                     {"by_feedback": pooled,
                      "slip_vibration_minus": {m: {"mean": v[0], "ci95": v[1]}
                                               for m, v in over.items()},
                      "reaction_s": mean_with_interval(
                          list(by_subject(rows, "reaction_s").values()))[0]})


def _eggs_arms(c: BoardConfig) -> dict[str, Arm]:
    forces = SMOKE_EGG_FORCES_N if c.smoke else EGG_FORCES_N
    return {f"eggs_{m}": Arm("eggs", {**clinical(c, user__feedback=m), "protocol.trials": 1},
                             variants=lambda s: [{"object.break_force_n": f} for f in forces])
            for m in ("none", "force_vibration")}


def _slope(rows: Rows) -> dict[int, float | None]:
    """Per subject: least-squares slope of success rate against log10 break force."""
    out: dict[int, float | None] = {}
    for s in sorted({int(r["subject_id"]) for r in rows}):
        mine = [r for r in rows if int(r["subject_id"]) == s]
        x = np.log10([float(r["break_force_n"]) for r in mine])
        y = np.array([float(r["success"]) / float(r["transfers"]) for r in mine])
        out[s] = float(np.polyfit(x, y, 1)[0]) if np.ptp(x) > 0 else None
    return out


def _judge_eggs(ev: Evidence, rng: np.random.Generator) -> Judgement:
    slope_mean, slope_ci = mean_with_interval(list(_slope(ev["eggs_none"]).values()))

    def mid(rows: Rows) -> Rows:
        return [r for r in rows if 2.0 <= float(r["break_force_n"]) <= 4.0]

    saved = paired_differences(subject_rate(mid(ev["eggs_force_vibration"]), "success",
                                            "transfers"),
                               subject_rate(mid(ev["eggs_none"]), "success", "transfers"))
    saved_mean, saved_ci = mean_with_interval(saved)
    up = Direction(+1)
    verdict = combine([up.verdict(slope_ci), up.verdict(saved_ci)])
    return Judgement(saved_mean, saved_ci, verdict,
                     {"slope_per_decade": {"mean": slope_mean, "ci95": slope_ci},
                      "saved_at_2_4_n": {"mean": saved_mean, "ci95": saved_ci,
                                         "pairs": len(saved)}})


def _force_arms(c: BoardConfig) -> dict[str, Arm]:
    targets = (0.4,) if c.smoke else (0.2, 0.4, 0.6)
    extra = {"protocol.episode_s": 5.0, "protocol.hold_s": 2.0} if c.smoke else {}
    return {f"force_{m}": Arm("force_matching", {**clinical(c, user__feedback=m), **extra},
                              variants=lambda s: [{"protocol.target_fraction": t}
                                                  for t in targets])
            for m in ("none", "force_vibration")}


def _judge_force(ev: Evidence, rng: np.random.Generator) -> Judgement:
    e = effect(ev["force_force_vibration"], ev["force_none"], "abs_error_n")
    return Judgement(e["mean"], e["ci95"], Direction(-1).verdict(e["ci95"]), {"effect": e})


def _rigid_arms(c: BoardConfig) -> dict[str, Arm]:
    return {"rigid": Arm("episode", clinical(c, user__feedback="none"),
                         variants=rigid_objects(c), seed_per_variant=True)}


def _judge_rigid(ev: Evidence, rng: np.random.Generator) -> Judgement:
    rows = ev["rigid"]
    held = sum(r["outcome"] == "held" for r in rows)
    rate, ci = rate_with_interval(int(held), len(rows))
    outcomes: dict[str, int] = {}
    for r in rows:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    return Judgement(rate, ci, Range(0.95, 1.0).verdict(rate, ci), {"outcomes": outcomes})


def _margin_arms(c: BoardConfig) -> dict[str, Arm]:
    return {"intact_rigid": Arm("episode", intact(c), variants=rigid_objects(c),
                                seed_per_variant=True)}


def _judge_margin(ev: Evidence, rng: np.random.Generator) -> Judgement:
    values = np.array([margin_over_grip_pct(float(r["safety_margin_pct"])) for r in
                       ev["intact_rigid"] if r.get("safety_margin_pct") is not None])
    figure = float(np.median(values)) if values.size else None
    ci = bootstrap_interval(lambda v: float(np.median(v)), values, rng) if values.size else None
    griploop = [float(r["safety_margin_pct"]) for r in ev["intact_rigid"]
                if r.get("safety_margin_pct") is not None]
    return Judgement(figure, ci, Range(10.0, 40.0).verdict(figure, ci),
                     {"held_lifts": int(values.size),
                      "median_margin_over_slip_pct": (float(np.median(griploop))
                                                      if griploop else None)})


BBT_SOURCE = "Mathiowetz et al. 1985 (the test)"
FINDINGS: tuple[Finding, ...] = (
    Finding(
        "bbt_intact", "Intact hands move 70-95 blocks a minute in the Box and Blocks Test",
        "Niama Natta et al. 2015, J Rehabil Med (adults 79-81, 89.1 under 25)",
        "79-89 blocks/min (young adults, dominant hand)",
        "range 70-95: agrees when the mean over subjects lies in it, disagrees when its "
        "95 % interval lies wholly outside", "blocks/min", (70.0, 95.0),
        _bbt_intact_arms, _judge_bbt_intact),
    Finding(
        "bbt_prosthesis", "Myoelectric users move 12-25 blocks a minute",
        "Kerver et al. 2023, JNER (standard hand 15.1 +/- 7.0, multi-grip 17.4 +/- 5.5)",
        "15.1-17.4 blocks/min",
        "range 12-25: agrees when the mean over subjects lies in it, disagrees when its "
        "95 % interval lies wholly outside", "blocks/min", (12.0, 25.0),
        lambda c: _bbt_prosthesis_arms(c), _judge_bbt_prosthesis),
    Finding(
        "bbt_ratio", "The prosthesis scores under a third of the intact hand",
        "Kerver et al. 2023; Niama Natta et al. 2015", "15-21 / 79-89 = 0.17-0.27",
        "range 0-1/3 on the ratio of mean scores (same subjects; interval: bootstrap over "
        "subjects): agrees when the ratio is below 1/3, disagrees when its interval lies "
        "wholly above", "ratio", (0.0, 1.0 / 3.0),
        lambda c: {**_bbt_intact_arms(c), **_bbt_prosthesis_arms(c)}, _judge_bbt_ratio),
    Finding(
        "bbt_feedback_with_vision",
        "With vision, vibrotactile feedback does not change the Box and Blocks score",
        "Markovic et al. 2018, JNER (6 amputees); MDC 6.5 blocks: Resnik & Borgia 2012",
        "no change beyond 6.5 blocks/min",
        "band +-6.5 on each mode's paired effect (mode - vision only): agrees when every "
        "mode's 95 % interval lies within it, disagrees when one lies wholly outside",
        "blocks/min", (-MDC_BLOCKS, MDC_BLOCKS),
        lambda c: _bbt_prosthesis_arms(c, ("none", "force_vibration", "slip_vibration")),
        _judge_bbt_feedback),
    Finding(
        "dark_transfers_feedback",
        "Without vision, vibration lowers the time per block and the drops (16 blocks)",
        "Raveh et al. 2018, Arch Phys Med Rehabil (12 users)",
        "4.2 vs 5.3 s per block; 2.0 vs 4.5 drops",
        "direction, both parts: the paired effects (force vibration - none) on time per "
        "block and on blocks dropped (before or beyond the partition) have 95 % intervals "
        "below zero: agrees; either above zero: disagrees", "s/block", (4.2 - 5.3, 0.0),
        _dark_arms, _judge_dark),
    Finding(
        "slip_opening_discrete",
        "A discrete slip vibration recovers an involuntary opening's slips, better than "
        "vision alone and than force vibration",
        "Aboseria et al. 2018, IEEE TNSRE", "close to 100 % recovered",
        "three parts: the recovered rate with slip vibration lies in 95-100 % (range rule); "
        "its paired excess over vision alone and over force vibration has a 95 % interval "
        "above zero (direction rule)", "recovered", (0.95, 1.0), _slip_arms, _judge_slip),
    Finding(
        "eggs_break_force",
        "Eggs: success rises with break force, and vibration saves eggs at 2-4 N",
        "Controzzi et al. 2025, IEEE TNSRE (Virtual Eggs Test); CALIBRATION.md",
        "success rises with break force; force feedback helps fragile grasps",
        "two directions: the per-subject slope of success on log break force (vision only) "
        "and the paired effect of force vibration on success at 2-4 N both have 95 % "
        "intervals above zero", "success", (0.0, 1.0), _eggs_arms, _judge_eggs),
    Finding(
        "force_matching_feedback", "Force-matching error falls with force feedback",
        "Chatterjee et al. 2008, JPO (vibrotactile: -25 %); Dosen et al. 2015, JNER",
        "error lower with feedback",
        "direction: the paired effect (force vibration - none) on the absolute error, "
        "averaged over the targets, has a 95 % interval below zero", "N", (-np.inf, 0.0),
        _force_arms, _judge_force),
    Finding(
        "rigid_held", "Practised users hold rigid everyday objects",
        "Mastinu et al. 2019, JNER; SHAP, J Hand Ther 2021 (failures are task-specific)",
        "rigid objects are not reported as failures (>= 95 % held)",
        "range 95-100 % on the held rate (Wilson interval)", "held", (0.95, 1.0),
        _rigid_arms, _judge_rigid),
    Finding(
        "intact_margin",
        "The intact hand's safety margin is 10-40 % (Westling & Johansson's definition)",
        "Westling & Johansson 1984, Exp Brain Res 53:277",
        "10-40 % of the grip above the slip force",
        "range 10-40 on the median relative margin (G - G_slip) / G over held lifts "
        "(bootstrap interval)", "%", (10.0, 40.0), _margin_arms, _judge_margin),
)
"""The board's rows, in the issue's order."""

FINDING_IDS = tuple(f.id for f in FINDINGS)
