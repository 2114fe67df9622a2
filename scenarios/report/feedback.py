"""Report section: the feedback benchmarks (eggs, slip recovery, force matching) side by side.

Reads the ``ok`` rows of kinds ``eggs``, ``slip_recovery`` and ``force_matching``
(:mod:`scenarios.runners.feedback_tasks`), groups them by controller, estimator
and user kind, and shows each feedback mode next to the others with 95 %
confidence intervals (Wilson for rates, Student t for means over subjects),
the same aggregation the commands print (:func:`scenarios.feedback_summary.aggregate`).
Registered as section ``feedback`` at order 85 (:mod:`scenarios.report.build`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from scenarios.feedback_summary import aggregate
from scenarios.report.html import Section, note, table
from scenarios.report.sections import ReportContext

TASK_KINDS = ("eggs", "slip_recovery", "force_matching")
TITLE = "9b. Feedback benchmarks: eggs, slip recovery, force matching"


def _pct(v: float | None) -> float | None:
    return None if v is None else 100.0 * v


def _ci(pair: Sequence[float | None] | None, scale: float = 1.0) -> str:
    if not pair or pair[0] is None or pair[1] is None:
        return "n/a"
    return f"[{pair[0] * scale:.3g}, {pair[1] * scale:.3g}]"


def _groups(rows: Sequence[Mapping[str, Any]]) -> dict[tuple[str, str, str], list[dict]]:
    out: dict[tuple[str, str, str], list[dict]] = {}
    for r in rows:
        res = r["result"]
        key = (res.get("controller", "?"), f"{res.get('estimator', '?')} ({res.get('mode', '?')})",
               res.get("user", "?"))
        out.setdefault(key, []).append(res)
    return out


def _eggs(result: Mapping[str, Any], label: str) -> list[str]:
    modes = result["by_feedback"]
    parts = [table(["feedback", "success %", "95 % CI", "transfers"],
                   [[m, _pct(v["success_rate"]), _ci(v["ci95"], 100), v["transfers"]]
                    for m, v in modes.items()], f"Virtual Eggs Test, {label}")]
    forces = sorted({e["break_force_n"] for v in modes.values() for e in v["eggs"]})
    rows = []
    for f in forces:
        row: list[Any] = [f]
        for v in modes.values():
            e = next((e for e in v["eggs"] if e["break_force_n"] == f), None)
            row += (["n/a"] * 4 if e is None else
                    [e["success"], e["broken"], e["dropped"], _ci(e["ci95"], 100)])
        rows.append(row)
    headers = ["break force (N)"] + [f"{m}: {h}" for m in modes
                                     for h in ("success", "broken", "dropped", "success 95 % CI")]
    parts.append(table(headers, rows, f"Outcomes per egg, {label}"))
    return parts


def _slip(result: Mapping[str, Any], label: str) -> list[str]:
    rows = [[m, v["n"], v["recovered"], _pct(v["recovered_rate"]), _ci(v["ci95"], 100),
             result["excluded"][m]["not_lifted"], result["excluded"][m]["no_slip"]]
            for m, v in result["by_feedback"].items()]
    return [table(["feedback", "slips", "recovered", "recovered %", "95 % CI", "not lifted",
                   "no slip"], rows, f"Slip recovery, {label}")]


def _force(result: Mapping[str, Any], label: str) -> list[str]:
    rows = [[m, t["target_fraction"], t["n"], t["abs_error_n"], _ci(t["abs_error_ci95"]),
             _pct(t["cv"]), _ci(t["cv_ci95"], 100), _pct(t.get("user_cv"))]
            for m, v in result["by_feedback"].items() for t in v["targets"]]
    rows.sort(key=lambda r: (r[1], str(r[0])))
    return [table(["feedback", "target (fraction of max)", "subjects", "abs error (N)", "95 % CI",
                   "hand CV %", "95 % CI", "user's own CV %"], rows,
                  f"Force matching, {label}")]


def feedback_section(context: ReportContext) -> Section:
    """The feedback benchmarks of the store, modes side by side (omitted without such rows)."""
    rows = [r for r in context.split.other if r["kind"] in TASK_KINDS]
    if not rows:
        return Section("feedback", TITLE, note("No eggs, slip-recovery or force-matching rows: "
                                               "section omitted."), True)
    parts = [note("Each feedback mode against the others on the same virtual subjects (the "
                  "benchmark sweeps pair them by seed). Rates with 95 % Wilson intervals; "
                  "errors and CVs are means over subjects with 95 % t intervals.")]
    builders = {"eggs": _eggs, "slip_recovery": _slip, "force_matching": _force}
    for kind in TASK_KINDS:
        mine = [r for r in rows if r["kind"] == kind]
        for (controller, estimator, user), results in _groups(mine).items():
            label = f"{controller}, {estimator}, {user} user"
            parts += builders[kind](aggregate(kind, results), label)
    return Section("feedback", TITLE, "\n".join(parts))

