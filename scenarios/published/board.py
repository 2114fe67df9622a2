"""Run the board: every finding's scenarios in one sweep, then one row per finding.

The findings' arms (:mod:`scenarios.published.findings`) expand into scenarios; a
scenario two findings share (the prosthesis's Box and Blocks with vision only serves
three rows) runs once. All of them run as one sweep
(:func:`scenarios.execution.sweep.run_sweep`: local workers, a results store, failures
recorded and the rest going on), so a ``--db`` board resumes where it stopped. Each
finding is then judged from its arms' rows; a finding whose scenarios could not be made,
or all failed, or whose judging raised, is a ``failed`` row with its one-line reason,
and the others still print.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from scenarios.published.arms import BoardConfig
from scenarios.published.findings import FINDINGS, Finding, Judgement
from scenarios.published.rules import AGREES, FAILED

#: Row keys of the board's JSON, in order (docs/FORMAT.md).
ROW_KEYS = ("id", "finding", "source", "rule", "published", "figure", "ci95", "verdict",
            "condition", "error")


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}".rstrip(": ")


def plan_findings(config: BoardConfig) -> tuple[dict[str, Any], dict[str, str]]:
    """Every finding's scenarios, keyed by content hash, and why a finding could not plan.

    Returns
    -------
    (plan, errors)
        ``plan[finding_id][arm] = [hash, ...]`` with ``plan["__scenarios__"] = {hash:
        PlannedScenario}``; ``errors[finding_id]`` the one-line reason a finding's
        scenarios could not be made.
    """
    from scenarios.execution.sweep import iter_plan
    from scenarios.schema import ExpandedScenario, parse_scenario

    scenarios: dict[str, Any] = {}
    plan: dict[str, Any] = {}
    errors: dict[str, str] = {}
    for finding in FINDINGS:
        try:
            arms: dict[str, list[str]] = {}
            for name, arm in finding.arms(config).items():
                hashes = []
                for subject, data in arm.scenarios(config.subjects, config.seed):
                    source = f"published {finding.id} {name} subject {subject}"
                    scenario = parse_scenario(data, source=source)
                    expanded = ExpandedScenario(len(scenarios), scenario,
                                                {"subject.subject_id": subject})
                    planned = next(iter(iter_plan([expanded])))
                    scenarios.setdefault(planned.hash, planned)
                    hashes.append(planned.hash)
                arms[name] = hashes
            plan[finding.id] = arms
        except Exception as exc:  # one finding that cannot be made never stops the board
            errors[finding.id] = _one_line(exc)
    plan["__scenarios__"] = scenarios
    return plan, errors


@contextmanager
def _store(db: Path | None) -> Iterator[Path]:
    if db is not None:
        yield db
        return
    with tempfile.TemporaryDirectory() as tmp:
        yield Path(tmp) / "published.sqlite"


def run_board(config: BoardConfig, *, workers: int = 1, db: Path | None = None,
              progress: bool = False) -> dict[str, Any]:
    """Run the board (module notes).

    Returns
    -------
    dict
        ``{"rows": [...], "agree": int, "total": int, "subjects": int, "seed": int}`` plus
        ``config``, ``scenarios`` (ok / failed) and ``elapsed_s``: docs/FORMAT.md.
    """
    from scenarios.execution.sweep import SweepExecution, run_sweep
    from scenarios.store import ResultStore

    t0 = time.perf_counter()
    plan, errors = plan_findings(config)
    scenarios = plan.pop("__scenarios__")
    # each planned scenario keeps its position in the board's sweep
    planned = [replace_index(p, i) for i, p in enumerate(scenarios.values())]
    name = sweep_name(config)
    with _store(db) as path, ResultStore(path) as store:
        if planned:
            run_sweep(planned, store, SweepExecution(workers=workers, time_limit_s=None),
                      sweep_name=name, progress=progress)
        stored = {r["hash"]: r for r in store.rows(sweep=name)} if planned else {}
    return judge_board(config, plan, errors, stored, time.perf_counter() - t0)


def judge_board(config: BoardConfig, plan: dict[str, Any], errors: dict[str, str],
                stored: dict[str, dict[str, Any]], elapsed_s: float) -> dict[str, Any]:
    """The board's JSON (docs/FORMAT.md) from the stored rows of its sweep."""
    rng_root = np.random.SeedSequence(config.seed)
    streams = rng_root.spawn(len(FINDINGS))
    rows = [board_row(finding, config, plan.get(finding.id), stored, errors.get(finding.id),
                      np.random.default_rng(streams[i]))
            for i, finding in enumerate(FINDINGS)]
    ok = sum(r["status"] == "ok" for r in stored.values())
    return {"rows": rows, "agree": sum(r["verdict"] == AGREES for r in rows),
            "total": len(rows), "subjects": config.subjects, "seed": config.seed,
            "config": asdict(config),
            "scenarios": {"ok": ok, "failed": len(stored) - ok}, "elapsed_s": elapsed_s}


SWEEP_PREFIX = "published"


def sweep_name(config: BoardConfig) -> str:
    """The board's sweep in a results store: its configuration, readable back by
    :func:`config_of_sweep` (the report judges a stored board from it)."""
    return (f"{SWEEP_PREFIX}-{config.paradigm}-{config.estimator}-{config.decoder}"
            f"-n{config.subjects}-seed{config.seed}{'-smoke' if config.smoke else ''}")


def config_of_sweep(name: str) -> BoardConfig | None:
    """The board configuration a sweep name says (None: not a board's sweep)."""
    parts = name.split("-")
    smoke = parts[-1] == "smoke"
    if smoke:
        parts = parts[:-1]
    if len(parts) != 6 or parts[0] != SWEEP_PREFIX or not parts[4].startswith("n") \
            or not parts[5].startswith("seed"):
        return None
    try:
        return BoardConfig(subjects=int(parts[4][1:]), seed=int(parts[5][4:]),
                           paradigm=parts[1], estimator=parts[2], decoder=parts[3],
                           smoke=smoke)
    except ValueError:
        return None


def replace_index(planned: Any, index: int) -> Any:
    """``planned`` at position ``index`` of the board's sweep."""
    from dataclasses import replace

    return replace(planned, index=index)


def board_row(finding: Finding, config: BoardConfig, arms: dict[str, list[str]] | None,
              stored: dict[str, dict[str, Any]], error: str | None,
              rng: np.random.Generator) -> dict[str, Any]:
    """One finding's row of the board (docs/FORMAT.md), judged from its arms' results."""
    row: dict[str, Any] = {"id": finding.id, "finding": finding.finding,
                           "source": finding.source, "rule": finding.rule,
                           "published": finding.published, "figure": None, "ci95": None,
                           "verdict": FAILED, "condition": condition(finding, config),
                           "error": error, "unit": finding.unit,
                           "published_range": list(finding.published_range)}
    if error is not None or arms is None:
        return row
    evidence: dict[str, list[dict[str, Any]]] = {}
    failures: list[str] = []
    for arm, hashes in arms.items():
        results = [stored.get(h) for h in hashes]
        evidence[arm] = [r["result"] for r in results if r and r["status"] == "ok"]
        failures += [(r.get("error") or "failed").splitlines()[0] if r else "not run"
                     for r in results if not r or r["status"] != "ok"]
        if not evidence[arm]:
            row["error"] = f"{arm}: every scenario failed ({failures[-1]})"
            return row
    row["condition"]["failed_scenarios"] = len(failures)
    try:
        judged: Judgement = finding.judge(evidence, rng)
    except Exception as exc:
        row["error"] = _one_line(exc)
        return row
    row.update(figure=judged.figure, ci95=None if judged.ci95 is None else list(judged.ci95),
               verdict=judged.verdict, details=judged.details)
    if failures:
        row["condition"]["first_failure"] = failures[0]
    return row


def condition(finding: Finding, config: BoardConfig) -> dict[str, Any]:
    """What a row ran under: the prosthesis's interface, or the intact hand's."""
    try:
        arms = list(finding.arms(config).values())
    except Exception:  # reported as the row's error; the condition is the board's
        arms = []
    hands = {a.settings.get("estimator.name") for a in arms}
    feedback = sorted({a.settings.get("user.feedback", "none") for a in arms})
    out: dict[str, Any] = {"subjects": config.subjects, "feedback": feedback}
    if hands == {"intact"}:
        out["hand"] = "intact (human speed, the user's own force, touch)"
    else:
        out.update(config.condition())
        if "intact" in hands:
            out["reference"] = "intact (human speed)"
    return out
