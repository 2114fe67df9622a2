"""Report section: the published scoreboard of a results store (``griploop published --db``).

A board's sweep is named after its configuration
(:func:`~scenarios.published.board.sweep_name`), so the report judges a stored board again
from its rows, by the same rules (:func:`~scenarios.published.board.judge_board`), and
shows it as a table and as one figure (the published range beside griploop's interval
per finding). Registered as section ``published`` at order 6, right after what the sweep
found.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from scenarios.report.html import Section, figure, img, note, table
from scenarios.report.sections import ReportContext

TITLE = "Published findings: the scoreboard"


def stored_boards(context: ReportContext) -> list[dict[str, Any]]:
    """Every board stored in the report's results, judged from its rows."""
    from scenarios.published.board import config_of_sweep, judge_board, plan_findings

    boards = []
    for name, members in context.members.items():
        config = config_of_sweep(name)
        if config is None:
            continue
        plan, errors = plan_findings(config)
        plan.pop("__scenarios__")
        stored = {r["hash"]: r for r in members}
        boards.append(judge_board(config, plan, errors, stored, elapsed_s=0.0))
    return boards


def _num(value: float | None) -> str:
    if value is None:
        return "n/a"
    return f"{value:.3g}"


def published_section(context: ReportContext) -> Section:
    """The stored boards (omitted when the store holds none)."""
    boards = stored_boards(context)
    if not boards:
        return Section("published", TITLE, note("No published board in this store "
                                                "(griploop published --db F): section "
                                                "omitted."), True)
    from scenarios.published.plot import plot_board

    parts = [note("Each row: a published human finding, its source and the rule its verdict "
                  "follows (docs/PUBLISHED.md); griploop's figure with its 95 % interval "
                  "over the same virtual subjects and seeds.")]
    for board in boards:
        cfg = board["config"]
        label = (f"{board['agree']} of {board['total']} agree; prosthesis {cfg['paradigm']}, "
                 f"{cfg['estimator']} free run, decoder {cfg['decoder']}; "
                 f"{board['subjects']} subjects, seed {board['seed']}"
                 f"{' (smoke: figures mean nothing)' if cfg['smoke'] else ''}")
        rows = [[r["id"], r["finding"], r["source"], r["published"],
                 _num(r["figure"]) + ("" if r["ci95"] is None else
                                      f" [{_num(r['ci95'][0])}, {_num(r['ci95'][1])}]"),
                 r["unit"], r["verdict"], r["error"] or "", r["rule"]]
                for r in board["rows"]]
        parts.append(table(["id", "finding", "source", "published", "griploop [95 % CI]",
                            "unit", "verdict", "error", "rule"], rows, label))
        with tempfile.TemporaryDirectory() as tmp:
            png = plot_board(board, Path(tmp) / "board.png").read_bytes()
        parts.append(figure(img(png, "the board: published ranges and griploop's "
                                     "intervals"), label))
    return Section("published", TITLE, "\n".join(parts))

