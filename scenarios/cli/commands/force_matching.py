"""``griploop force-matching``: hold target forces; absolute error and CV per feedback mode."""

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

HELP = "hold target grip forces: absolute error and CV, feedback modes side by side"


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``force-matching`` subcommand."""
    p = subparsers.add_parser(
        "force-matching", help=HELP,
        description="Each virtual subject closes the hand on a block on the table and holds "
        "each target (a fraction of the hand force at their MVC) for the last 5 s of an 8 s "
        "trial; prints the absolute error of the mean grip and its coefficient of variation "
        "per target and feedback mode, means over subjects with 95 % t intervals. The design "
        "is scenarios/library/force_matching.yaml with these options.")
    add_common_options(p, default_feedback="none,force_vibration", default_subjects=10)
    p.add_argument("--targets", default="0.2,0.4,0.6", metavar="LIST",
                   help="target fractions of the maximum, comma-separated (default 0.2,0.4,0.6)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop force-matching``; returns the exit status."""
    targets = comma_list("--targets", args.targets, float)
    bad = [t for t in targets if not 0 < t <= 1]
    if bad:
        raise UsageError(f"--targets: expected fractions in (0, 1], found {bad}")
    return run_task(args, "force_matching", grid={"protocol.target_fraction": targets},
                    table=format_force_matching)


def format_force_matching(result: dict[str, Any]) -> str:
    """Absolute error and CV per target and mode, with their intervals."""
    lines = [f"{'target':>7}  {'feedback':<24}{'abs error N':>12}{'95 % CI':>16}{'CV %':>7}"
             f"{'95 % CI':>16}{'user CV %':>10}{'n':>4}"]
    rows = [(t["target_fraction"], mode, t) for mode, m in with_intact(result).items()
            for t in m["targets"]]
    for frac, mode, t in sorted(rows, key=lambda r: r[0]):
        lines.append(f"{frac:>7.0%}  {mode:<24}{fmt(t['abs_error_n']):>12}"
                     f"{ci_text(t['abs_error_ci95']):>16}{fmt(t['cv'], '.1f', 100):>7}"
                     f"{ci_text(t['cv_ci95'], '.1f', 100):>16}"
                     f"{fmt(t.get('user_cv'), '.1f', 100):>10}{t['n']:>4}")
    lines.append("CV: the hand's grip force; user CV: the user's own force, mapped to the hand")
    return "\n".join(lines)
