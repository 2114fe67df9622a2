"""``griploop transfers``: blocks moved per minute (Box and Blocks style), prosthesis and intact."""

from __future__ import annotations

import argparse
from typing import Any

from scenarios.cli.errors import UsageError
from scenarios.cli.feedback_tasks import add_common_options, ci_text, fmt, run_task

HELP = "timed transfers (Box and Blocks style): blocks per minute, prosthesis and intact hand"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``transfers`` subcommand."""
    p = subparsers.add_parser(
        "transfers", help=HELP,
        description="Each practised virtual subject moves blocks over a 15.2 cm partition, "
        "one at a time, for --duration-s (the Box and Blocks Test's 60 s): grasp, lift when "
        "the grip looks secure, carry over, put down and let go, then reach back for the next. "
        "Prints blocks per minute with a 95 % interval over subjects, drops and breaks, for "
        "the prosthesis and for the intact-hand reference (the user's own force drives the "
        "hand, no sEMG path, felt by touch). The design is scenarios/library/transfers.yaml "
        "with these options.")
    add_common_options(p, default_feedback="none", default_subjects=10)
    p.add_argument("--duration-s", type=float, default=60.0, metavar="S",
                   help="how long the user moves blocks, s (default 60)")
    p.add_argument("--object", default=None, metavar="NAME",
                   help="the block (default transfer_block, a 50 mm cube)")
    p.add_argument("--break-force-n", type=float, default=None, metavar="N",
                   help="a fragile block breaking at this grip force, N (default: it does not "
                   "break)")
    p.set_defaults(func=run, intact=True)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop transfers``; returns the exit status."""
    if not 10.0 <= args.duration_s <= 600.0:
        raise UsageError(f"--duration-s: expected 10..600 s, found {args.duration_s:g}")
    base: dict[str, Any] = {"protocol.duration_s": args.duration_s}
    if args.object is not None:
        from scenarios.cli.choices import check_choice, object_names

        base["object.name"] = check_choice("--object", args.object, object_names())
    if args.break_force_n is not None:
        if not args.break_force_n > 0:
            raise UsageError(f"--break-force-n: expected a force > 0 N, found "
                             f"{args.break_force_n:g}")
        base["object.break_force_n"] = args.break_force_n
    args.intact = True
    return run_task(args, "transfers", base=base, table=format_transfers, feedback_grid=False)


def format_transfers(result: dict[str, Any]) -> str:
    """Blocks per minute with its interval, drops and breaks: the prosthesis, then intact."""
    lines = [f"{'hand':<24}{'blocks/min':>11}{'95 % CI':>16}{'drops':>7}{'breaks':>8}"
             f"{'not released':>14}{'s/block':>9}"]
    arms = [("prosthesis", result)]
    if "intact" in result:
        arms.append(("intact-hand reference", result["intact"]))
    for name, r in arms:
        lines.append(f"{name:<24}{fmt(r['blocks_per_min'], '.1f'):>11}"
                     f"{ci_text(r['ci95'], '.1f'):>16}{r['drops']:>7}{r['breaks']:>8}"
                     f"{r['not_released']:>14}{fmt(r['transfer_s'], '.2f'):>9}")
    if "intact" in result and result["blocks_per_min"]:
        ratio = result["intact"]["blocks_per_min"] / result["blocks_per_min"]
        lines.append(f"intact / prosthesis: {ratio:.2f}x")
    return "\n".join(lines)
