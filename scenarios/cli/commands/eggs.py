"""``griploop eggs``: the Virtual Eggs Test, feedback modes side by side."""

from __future__ import annotations

import argparse
from typing import Any

from scenarios.cli.errors import UsageError
from scenarios.cli.feedback_tasks import (
    add_common_options,
    ci_text,
    comma_list,
    fmt,
    run_task,
    with_intact,
)

HELP = "Virtual Eggs Test: transfer 11 fragile blocks, feedback modes side by side"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``eggs`` subcommand."""
    p = subparsers.add_parser(
        "eggs", help=HELP,
        description="Virtual Eggs Test (Controzzi et al.): each virtual subject grasps, lifts "
        "and holds each of 11 blocks breaking at 0.4-11.5 N several times (planning each "
        "transfer from the last), with each feedback mode; every transfer is a success, broken "
        "or dropped. Prints the success rate per mode with its 95 % Wilson interval and the "
        "outcomes per egg. The design is scenarios/library/eggs.yaml with these options.")
    add_common_options(p, default_feedback="none,force_vibration", default_subjects=5)
    p.add_argument("--transfers", type=int, default=3, metavar="K",
                   help="transfers of each egg per subject and mode (default 3)")
    p.add_argument("--eggs", default=None, metavar="LIST",
                   help="break forces in N, comma-separated (default the 11 of the test, "
                   "0.4-11.5 N log-spaced)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop eggs``; returns the exit status."""
    if args.transfers < 1:
        raise UsageError(f"--transfers: expected at least 1, found {args.transfers}")
    grid = {}
    if args.eggs is not None:
        grid["object.break_force_n"] = comma_list("--eggs", args.eggs, float)
    else:
        from scenarios.runners.feedback_tasks import EGG_BREAK_FORCES_N

        grid["object.break_force_n"] = list(EGG_BREAK_FORCES_N)
    return run_task(args, "eggs", base={"protocol.trials": args.transfers}, grid=grid,
                    table=format_eggs)


def format_eggs(result: dict[str, Any]) -> str:
    """Success rate per mode, then success / broken / dropped per egg and mode."""
    modes = with_intact(result)
    lines = [f"{'feedback':<24}{'success rate':>13}{'95 % CI':>18}{'transfers':>11}"]
    for mode, m in modes.items():
        lines.append(f"{mode:<24}{fmt(m['success_rate'], '.0f', 100) + ' %':>13}"
                     f"{ci_text(m['ci95'], '.0f', 100):>18}{m['transfers']:>11}")
    lines.append("")
    lines.append(f"{'break N':>8}" + "".join(f"{mode + ' s/b/d':>26}" for mode in modes))
    forces = sorted({e["break_force_n"] for m in modes.values() for e in m["eggs"]})
    for f in forces:
        cells = []
        for m in modes.values():
            e = next((e for e in m["eggs"] if e["break_force_n"] == f), None)
            cells.append("-" if e is None else f"{e['success']}/{e['broken']}/{e['dropped']}")
        lines.append(f"{f:>8.2f}" + "".join(f"{c:>26}" for c in cells))
    return "\n".join(lines)
