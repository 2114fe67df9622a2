"""``griploop transfers``: the Box and Blocks Test, blocks per minute, prosthesis and intact."""

from __future__ import annotations

import argparse
from typing import Any

from scenarios.cli.errors import UsageError
from scenarios.cli.feedback_tasks import add_common_options, ci_text, fmt, run_task

HELP = "the Box and Blocks Test: blocks per minute, prosthesis and intact hand"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``transfers`` subcommand."""
    p = subparsers.add_parser(
        "transfers", help=HELP,
        description="The Box and Blocks Test as published: each practised virtual subject "
        "moves the test's 25 mm cubes over a 15.2 cm partition, one at a time, for "
        "--duration-s (60 s): grasp, lift when the grip looks secure, carry over, put down "
        "and let go, then reach back for the next. A block counts once carried over the "
        "partition and let go, or dropped beyond it. Prints blocks per minute with a 95 % "
        "interval over subjects, drops and breaks, for the prosthesis and for the two "
        "references the user's own force drives (no sEMG path, felt by touch): the intact hand "
        "(pre-shaped, human speed, grip coupled to load) and the ideal interface (the "
        "prosthesis's hand); "
        "several --feedback modes run on the same subjects and seeds. The design is "
        "scenarios/library/transfers.yaml with these options.")
    add_common_options(p, default_feedback="none", default_subjects=10)
    p.add_argument("--duration-s", type=float, default=60.0, metavar="S",
                   help="how long the user moves blocks, s (default 60)")
    p.add_argument("--object", default="bbt_cube", metavar="NAME",
                   help="the block (default bbt_cube, the test's 25 mm wooden cube; "
                   "transfer_block: griploop's 50 mm one)")
    p.add_argument("--reach-s", type=float, default=None, metavar="S",
                   help="the arm's reach back for the next block, s (default: the user's "
                   "lift_s, 0.6 s)")
    p.add_argument("--transport-s", type=float, default=None, metavar="S",
                   help="the arm's carry over the partition, s (default: the user's lift_s, "
                   "0.6 s)")
    p.add_argument("--blocks", type=int, default=None, metavar="N",
                   help="untimed: move N blocks, each once, and report the time per block and "
                   "the blocks dropped (Raveh et al. 2018's test: 16, with --vision off)")
    p.add_argument("--break-force-n", type=float, default=None, metavar="N",
                   help="a fragile block breaking at this grip force, N (default: it does not "
                   "break)")
    p.set_defaults(func=run, intact=True)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop transfers``; returns the exit status."""
    if not 10.0 <= args.duration_s <= 600.0:
        raise UsageError(f"--duration-s: expected 10..600 s, found {args.duration_s:g}")
    from scenarios.cli.choices import check_choice, object_names

    base: dict[str, Any] = {"protocol.duration_s": args.duration_s}
    base["object.name"] = check_choice("--object", args.object, object_names())
    for flag, value, path in (("--reach-s", args.reach_s, "protocol.reach_s"),
                              ("--transport-s", args.transport_s, "protocol.transport_s")):
        if value is not None:
            if not 0.1 <= value <= 3.0:
                raise UsageError(f"{flag}: expected 0.1..3 s, found {value:g}")
            base[path] = value
    if args.blocks is not None:
        if not 1 <= args.blocks <= 60:
            raise UsageError(f"--blocks: expected 1..60, found {args.blocks}")
        base["protocol.blocks"] = args.blocks
    if args.break_force_n is not None:
        if not args.break_force_n > 0:
            raise UsageError(f"--break-force-n: expected a force > 0 N, found "
                             f"{args.break_force_n:g}")
        base["object.break_force_n"] = args.break_force_n
    args.intact = True
    return run_task(args, "transfers", base=base, table=format_transfers, feedback_grid=False)


def format_transfers(result: dict[str, Any]) -> str:
    """Blocks per minute with its interval, drops and breaks: the prosthesis (each feedback
    mode when several ran), then intact."""
    lines = [f"{'hand':<32}{'blocks/min':>11}{'95 % CI':>16}{'beyond':>8}{'drops':>7}"
             f"{'breaks':>8}{'not released':>14}{'s/block':>9}{'s/transfer':>11}"]
    modes = result.get("by_feedback")
    arms = ([(f"prosthesis, {m}", r) for m, r in modes.items()] if modes
            else [("prosthesis", result)])
    if "intact" in result:
        arms.append(("intact hand (human speed)", result["intact"]))
    if "ideal_interface" in result:
        arms.append(("ideal interface", result["ideal_interface"]))
    for name, r in arms:
        lines.append(f"{name:<32}{fmt(r['blocks_per_min'], '.1f'):>11}"
                     f"{ci_text(r['ci95'], '.1f'):>16}{r.get('dropped_beyond', 0):>8}"
                     f"{r['drops']:>7}{r['breaks']:>8}{r['not_released']:>14}"
                     f"{fmt(r['transfer_s'], '.2f'):>9}"
                     f"{fmt(r.get('time_per_block_s'), '.2f'):>11}")
    if "intact" in result and result["blocks_per_min"]:
        ratio = result["intact"]["blocks_per_min"] / result["blocks_per_min"]
        lines.append(f"intact / prosthesis: {ratio:.2f}x")
    return "\n".join(lines)
