"""``griploop slip-recovery``: a rising load until the object slips; is it recovered?"""

from __future__ import annotations

import argparse
from typing import Any

from scenarios.cli.errors import UsageError
from scenarios.cli.feedback_tasks import add_common_options, ci_text, fmt, run_task, with_intact

HELP = "recover an object whose load rises until it slips, feedback modes side by side"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``slip-recovery`` subcommand."""
    p = subparsers.add_parser(
        "slip-recovery", help=HELP,
        description="Each virtual subject lifts the can and holds it while a load hung on it "
        "rises until the can starts to slip, then stays; the trial is recovered if the can is "
        "still held 2 s later. Prints the recovered rate per feedback mode with its 95 % "
        "Wilson interval. The design is scenarios/library/slip_recovery.yaml with these "
        "options.")
    add_common_options(p, default_feedback="none,slip_vibration", default_subjects=10)
    p.add_argument("--trials", type=int, default=3, metavar="K",
                   help="slipping loads per subject and mode (default 3)")
    p.add_argument("--load-rate", type=float, default=None, metavar="N_PER_S",
                   help="rate at which the load rises, N/s (default 1)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop slip-recovery``; returns the exit status."""
    if args.trials < 1:
        raise UsageError(f"--trials: expected at least 1, found {args.trials}")
    base: dict[str, Any] = {"protocol.trials": args.trials}
    if args.load_rate is not None:
        base["protocol.load_rate_n_s"] = args.load_rate
    return run_task(args, "slip_recovery", base=base, table=format_slip_recovery)


def format_slip_recovery(result: dict[str, Any]) -> str:
    """Recovered rate per mode with its interval, and the trials left out (intact hand last)."""
    lines = [f"{'feedback':<18}{'n':>5}{'recovered':>11}{'rate':>8}{'95 % CI':>16}"
             f"{'not lifted':>12}{'no slip':>9}"]
    excluded = with_intact(result, "excluded")
    for mode, m in with_intact(result).items():
        ex = excluded[mode]
        lines.append(f"{mode:<18}{m['n']:>5}{m['recovered']:>11}"
                     f"{fmt(m['recovered_rate'], '.0f', 100) + ' %':>8}"
                     f"{ci_text(m['ci95'], '.0f', 100):>16}{ex['not_lifted']:>12}"
                     f"{ex['no_slip']:>9}")
    return "\n".join(lines)
