"""Summaries of the benchmarks: feedback modes side by side with 95 % intervals.

The JSON of ``griploop eggs``, ``slip-recovery``, ``force-matching`` and ``transfers``
(documented in docs/FORMAT.md) and the report's feedback section both come from
:func:`aggregate` of the result rows of :mod:`scenarios.runners.feedback_tasks` and
:mod:`scenarios.runners.transfers`. Plain data, no simulation: the report may import it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from scenarios.stats import mean_interval, wilson_interval


def _ci(pair: tuple[float, float]) -> list[float | None]:
    return [None if math.isnan(v) else float(v) for v in pair]


def aggregate_eggs(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The ``eggs`` JSON contract (docs/FORMAT.md) from ``eggs`` result rows.

    ``{"by_feedback": {MODE: {"success_rate", "ci95", "transfers", "eggs": [{"break_force_n",
    "transfers", "success", "broken", "dropped", "ci95"}]}}}``, eggs by break force.
    """
    out: dict[str, Any] = {}
    for mode in _modes(rows):
        mine = [r for r in rows if r["feedback"] == mode]
        eggs = []
        for f in sorted({float(r["break_force_n"]) for r in mine}):
            egg = [r for r in mine if float(r["break_force_n"]) == f]
            counts = {k: int(sum(r[k] for r in egg))
                      for k in ("transfers", "success", "broken", "dropped")}
            eggs.append({"break_force_n": f, **counts,
                         "ci95": _ci(wilson_interval(counts["success"], counts["transfers"]))})
        total = sum(e["transfers"] for e in eggs)
        success = sum(e["success"] for e in eggs)
        out[mode] = {"success_rate": success / total if total else None,
                     "ci95": _ci(wilson_interval(success, total)), "transfers": total,
                     "eggs": eggs}
    return {"by_feedback": out}


def aggregate_slip_recovery(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The ``slip-recovery`` JSON contract (docs/FORMAT.md) from ``slip_recovery`` rows.

    ``{"by_feedback": {MODE: {"n", "recovered", "recovered_rate", "ci95", "no_slip",
    "reaction_s", "reaction_ci95"}}, "excluded": {MODE: {"not_lifted", "no_slip"}}}``:
    ``ci95`` the Wilson interval of the recovered rate; ``reaction_s`` the mean over
    subjects of their mean reaction (rows with one) with a Student-t interval.
    """
    out: dict[str, Any] = {}
    excluded: dict[str, Any] = {}
    for mode in _modes(rows):
        mine = [r for r in rows if r["feedback"] == mode]
        n = int(sum(r["n"] for r in mine))
        k = int(sum(r["recovered"] for r in mine))
        reaction = mean_interval([r.get("reaction_s") for r in mine])
        out[mode] = {"n": n, "recovered": k, "recovered_rate": k / n if n else None,
                     "ci95": _ci(wilson_interval(k, n)),
                     "no_slip": int(sum(r["no_slip"] for r in mine)),
                     "reaction_s": _num(reaction[0]), "reaction_ci95": _ci(reaction[1:])}
        excluded[mode] = {key: int(sum(r[key] for r in mine)) for key in ("not_lifted", "no_slip")}
    return {"by_feedback": out, "excluded": excluded}


def aggregate_force_matching(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The ``force-matching`` JSON contract (docs/FORMAT.md) from ``force_matching`` rows.

    ``{"by_feedback": {MODE: {"targets": [{"target_fraction", "abs_error_n", "cv",
    "abs_error_ci95", "cv_ci95", "user_cv", "time_to_target_s", "time_to_target_ci95",
    "n"}]}}}``: means over subjects with Student-t intervals; ``cv`` is the hand's grip
    force, ``user_cv`` the user's own; ``time_to_target_s`` over the subjects whose grip
    reached the target.
    """
    out: dict[str, Any] = {}
    for mode in _modes(rows):
        mine = [r for r in rows if r["feedback"] == mode]
        targets = []
        for frac in sorted({float(r["target_fraction"]) for r in mine}):
            rs = [r for r in mine if float(r["target_fraction"]) == frac]
            err = mean_interval([r["abs_error_n"] for r in rs])
            cv = mean_interval([r["cv"] for r in rs])
            user_cv = mean_interval([r.get("user_cv") for r in rs])
            reach = mean_interval([r.get("time_to_target_s") for r in rs])
            targets.append({"target_fraction": frac, "abs_error_n": _num(err[0]),
                            "cv": _num(cv[0]), "abs_error_ci95": _ci(err[1:]),
                            "cv_ci95": _ci(cv[1:]), "user_cv": _num(user_cv[0]),
                            "time_to_target_s": _num(reach[0]),
                            "time_to_target_ci95": _ci(reach[1:]), "n": len(rs)})
        out[mode] = {"targets": targets}
    return {"by_feedback": out}


def aggregate_transfers(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The ``transfers`` JSON contract (docs/FORMAT.md) from ``transfers`` rows (one arm).

    ``{"blocks_per_min", "ci95", "transfers", "dropped_beyond", "drops", "breaks",
    "not_released", "not_cleared", "not_lifted", "transfer_s", "subjects", "per_subject"}``:
    blocks per minute averaged over subjects with a Student-t interval (one row per subject),
    counts summed (``transfers``: the transfers started; ``dropped_beyond``: blocks that
    fell after they were carried over the partition, scored as moved), ``transfer_s`` the
    mean time of a scored block, ``time_per_block_s`` (with ``time_per_block_ci95``) the
    mean over subjects of their transfers' time over their number (Raveh et al.'s figure),
    ``blocks_dropped`` the blocks that fell (before or beyond the partition). Rows of
    several feedback modes (the same subjects and seeds) add ``by_feedback`` (mode -> the
    same summary); the top level is the first mode's.
    """
    modes = list(dict.fromkeys(r.get("feedback") for r in rows))
    if len(modes) > 1:
        by_mode = {m: _transfers_summary([r for r in rows if r.get("feedback") == m])
                   for m in modes}
        return {**by_mode[modes[0]], "by_feedback": by_mode}
    return _transfers_summary(rows)


def _transfers_summary(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    rate = mean_interval([r["blocks_per_min"] for r in rows])
    times = [r["transfer_s"] for r in rows if r.get("transfer_s") is not None]
    per_block = [r["time_per_block_s"] for r in rows if r.get("time_per_block_s") is not None]
    per_block_ci = mean_interval(per_block) if per_block else (math.nan, math.nan, math.nan)
    return {"blocks_per_min": _num(rate[0]), "ci95": _ci(rate[1:]),
            "time_per_block_s": _num(per_block_ci[0]),
            "time_per_block_ci95": _ci(per_block_ci[1:]),
            **{k: int(sum(r.get(k) or 0 for r in rows))
               for k in ("transfers", "dropped_beyond", "drops", "breaks", "not_released",
                         "not_cleared", "not_lifted", "blocks_dropped")},
            "transfer_s": float(sum(times) / len(times)) if times else None,
            "subjects": len(rows),
            "per_subject": [{"subject_id": r["subject_id"], "blocks_per_min": r["blocks_per_min"]}
                            for r in rows]}


def _num(v: float) -> float | None:
    return None if math.isnan(v) else float(v)


def _modes(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    return list(dict.fromkeys(r["feedback"] for r in rows))


AGGREGATES: dict[str, Callable[[Sequence[Mapping[str, Any]]], dict[str, Any]]] = {
    "eggs": aggregate_eggs, "slip_recovery": aggregate_slip_recovery,
    "force_matching": aggregate_force_matching, "transfers": aggregate_transfers}
"""Scenario kind -> the aggregation of its rows into the command's JSON."""


def aggregate(kind: str, rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The JSON of a task command from its result rows (flat dicts of one kind)."""
    return AGGREGATES[kind](rows)
