"""``griploop slip-recovery``: a held object made to slip (a rising load, or an involuntary
opening of the hand); is it recovered?"""

from __future__ import annotations

import argparse
import math
from typing import Any

from scenarios.cli.choices import check_choice
from scenarios.cli.errors import UsageError
from scenarios.cli.feedback_tasks import add_common_options, ci_text, fmt, run_task, with_intact

HELP = ("recover a held object made to slip (rising load or involuntary opening), feedback modes "
        "side by side")
#: The perturbations ``--perturbation`` takes (:mod:`scenarios.runners.slip_perturbations`).
PERTURBATIONS = ("rising_load", "opening")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``slip-recovery`` subcommand."""
    p = subparsers.add_parser(
        "slip-recovery", help=HELP,
        description="Each virtual subject lifts the can and holds it until it is made to slip: "
        "by default a load hung on it rises until the can starts to slip, then stays "
        "(griploop's protocol); with --perturbation opening the hand's command drops at an "
        "unannounced time and stays dropped until the user squeezes harder (Aboseria et al. "
        "2018's involuntary opening). The trial is recovered if the can is still held 2 s "
        "after the slip began. Prints the recovered rate per feedback mode with its 95 % "
        "Wilson interval, the openings or loads that made no slip, and the mean reaction. "
        "The design is scenarios/library/slip_recovery.yaml with these options.")
    add_common_options(p, default_feedback="none,slip_vibration", default_subjects=10)
    p.add_argument("--trials", type=int, default=3, metavar="K",
                   help="perturbations per subject and mode (default 3)")
    p.add_argument("--perturbation", default="rising_load", metavar="KIND",
                   help="what makes the can slip: rising_load (default) or opening")
    p.add_argument("--load-rate", type=float, default=None, metavar="N_PER_S",
                   help="rising_load: rate at which the load rises, N/s (default 1)")
    p.add_argument("--opening", type=float, default=None, metavar="F",
                   help="opening: fraction of the hand's command lost, in (0, 1] (default 0.5)")
    p.set_defaults(func=run)


def protocol_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options as scenario paths, each left out at its default (no seed moves).

    Raises
    ------
    UsageError
        One line naming the flag: fewer than one trial, an opening outside (0, 1], or an
        option of the other perturbation.
    """
    if args.trials < 1:
        raise UsageError(f"--trials: expected at least 1, found {args.trials}")
    check_choice("--perturbation", args.perturbation, PERTURBATIONS)
    base: dict[str, Any] = {"protocol.trials": args.trials}
    opening = args.perturbation == "opening"
    if args.opening is not None:
        if not opening:
            raise UsageError("--opening: applies to --perturbation opening, found "
                             f"--perturbation {args.perturbation}")
        if not (math.isfinite(args.opening) and 0.0 < args.opening <= 1.0):
            raise UsageError(f"--opening: expected a fraction in (0, 1], found {args.opening:g}")
        base["protocol.opening"] = args.opening
    if args.load_rate is not None:
        if opening:
            raise UsageError("--load-rate: applies to --perturbation rising_load, found "
                             "--perturbation opening")
        base["protocol.load_rate_n_s"] = args.load_rate
    if opening:
        base["protocol.perturbation"] = "opening"
    return base


def run(args: argparse.Namespace) -> int:
    """Run ``griploop slip-recovery``; returns the exit status."""
    return run_task(args, "slip_recovery", base=protocol_options(args),
                    table=format_slip_recovery)


def perturbation_text(settings: dict[str, Any]) -> str:
    """Which perturbation ran, from the JSON's ``settings``."""
    if settings.get("protocol.perturbation", "rising_load") == "opening":
        return (f"perturbation: involuntary opening, {settings.get('protocol.opening', 0.5):g} "
                "of the command lost at an unannounced time (Aboseria et al. 2018)")
    return (f"perturbation: rising load, {settings.get('protocol.load_rate_n_s', 1.0):g} N/s "
            "until the object slips (griploop's)")


def format_slip_recovery(result: dict[str, Any]) -> str:
    """Per mode the recovered rate with its interval, the mean reaction and the trials left
    out (intact hand last); then which perturbation ran."""
    lines = [f"{'feedback':<24}{'n':>5}{'recovered':>11}{'rate':>8}{'95 % CI':>16}"
             f"{'reaction s':>12}{'not lifted':>12}{'no slip':>9}"]
    excluded = with_intact(result, "excluded")
    for mode, m in with_intact(result).items():
        ex = excluded[mode]
        lines.append(f"{mode:<24}{m['n']:>5}{m['recovered']:>11}"
                     f"{fmt(m['recovered_rate'], '.0f', 100) + ' %':>8}"
                     f"{ci_text(m['ci95'], '.0f', 100):>16}"
                     f"{fmt(m.get('reaction_s'), '.2f'):>12}{ex['not_lifted']:>12}"
                     f"{ex['no_slip']:>9}")
    lines.append(perturbation_text(result.get("settings", {})))
    return "\n".join(lines)
