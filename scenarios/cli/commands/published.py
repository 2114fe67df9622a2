"""``griploop published``: the scoreboard of published human findings (docs/PUBLISHED.md)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from scenarios.cli.errors import UsageError

HELP = "the scoreboard: which published human findings griploop reproduces"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``published`` subcommand."""
    p = subparsers.add_parser(
        "published", help=HELP,
        description="Run each published finding's protocol (Box and Blocks with the intact "
        "hand and the prosthesis, feedback with and without vision, slip by involuntary "
        "opening, the Virtual Eggs Test, force matching, rigid objects, the intact hand's "
        "safety margin) on the same virtual subjects and seeds, and print one row per "
        "finding: its source, the published figure, griploop's figure with its 95 % "
        "interval, and the verdict (agrees, disagrees, inconclusive) by the rule stated "
        "in docs/PUBLISHED.md.")
    p.add_argument("--subjects", type=int, default=10, metavar="N",
                   help="virtual subjects 1..N (default 10)")
    p.add_argument("--seed", type=int, default=37, metavar="S", help="board seed (default 37)")
    p.add_argument("--paradigm", default="velocity", metavar="NAME",
                   help="the prosthesis's paradigm (default velocity, the clinical one)")
    p.add_argument("--estimator", default="ss_kf", metavar="NAME",
                   help="force estimator, free run (default ss_kf)")
    p.add_argument("--decoder", default="pattern", metavar="NAME",
                   help="open/close decoder of a paradigm that needs one (default pattern)")
    p.add_argument("--smoke", action="store_true",
                   help="1 subject, shortened protocols, no practice: checks the board is "
                   "well formed; its figures mean nothing")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="worker processes (default 1)")
    p.add_argument("--db", type=Path, default=None, metavar="PATH",
                   help="results store (resumable; default a temporary one)")
    p.add_argument("--plot", type=Path, default=None, metavar="F.png",
                   help="also draw the board as one figure")
    p.add_argument("--json", type=Path, default=None, metavar="F", help="write the board here")
    p.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop published``; returns the exit status."""
    from controllers.paradigms import paradigm_names
    from estimation.decoding import decoder_names
    from scenarios.cli.choices import check_choice, estimator_choices
    from scenarios.published.arms import BoardConfig
    from scenarios.published.board import run_board

    subjects = 1 if args.smoke else args.subjects
    if subjects < 1:
        raise UsageError(f"--subjects: expected at least 1, found {args.subjects}")
    if args.workers < 1:
        raise UsageError(f"--workers: expected at least 1, found {args.workers}")
    check_choice("--paradigm", args.paradigm, paradigm_names())
    check_choice("--estimator", args.estimator, estimator_choices())
    check_choice("--decoder", args.decoder, decoder_names())
    config = BoardConfig(subjects=subjects, seed=args.seed, paradigm=args.paradigm,
                         estimator=args.estimator, decoder=args.decoder, smoke=args.smoke)
    board = run_board(config, workers=args.workers, db=args.db,
                      progress=not args.no_progress)
    print(format_board(board))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(board, indent=1))
        print(f"wrote {args.json}")
    if args.plot is not None:
        from scenarios.published.plot import plot_board

        print(f"wrote {plot_board(board, args.plot)}")
    return 0


def _num(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.3g}" if abs(value) < 10 else f"{value:.1f}"


def format_board(board: dict[str, Any]) -> str:
    """The board as a text table: one row per finding."""
    lines = [f"{'finding':<26}{'published':<44}{'griploop [95 % CI]':<28}verdict"]
    for row in board["rows"]:
        ci = row["ci95"]
        ours = _num(row["figure"]) + ("" if ci is None else f" [{_num(ci[0])}, {_num(ci[1])}]")
        lines.append(f"{row['id']:<26}{row['published'][:42]:<44}{ours:<28}{row['verdict']}")
        if row["error"]:
            lines.append(f"{'':<26}{row['error']}")
    cfg = board["config"]
    lines.append(f"{board['agree']} of {board['total']} findings agree ({board['subjects']} "
                 f"subjects, seed {board['seed']}; prosthesis: {cfg['paradigm']}, "
                 f"{cfg['estimator']} free run; {board['scenarios']['ok']} scenarios ok, "
                 f"{board['scenarios']['failed']} failed, {board['elapsed_s']:.0f} s)")
    return "\n".join(lines)
