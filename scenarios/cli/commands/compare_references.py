"""``griploop compare-references``: the same grasp driven by different force references."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from controllers.design_plant import object_for
from scenarios.cli.choices import (
    add_hand_options,
    add_user_options,
    check_hand_options,
    check_practice_window,
    check_user_options,
    controller_names,
    estimator_choices,
    object_names,
)
from scenarios.cli.errors import UnknownChoiceError, UsageError
from scenarios.runners.compare import DEFAULT_REFERENCES, compare_references, format_comparison
from scenarios.runners.episode import EpisodeSpec
from scenarios.runners.trial_loop import HandSettings


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``compare-references`` subcommand."""
    p = subparsers.add_parser(
        "compare-references",
        help="grasp one object with references from several estimators and the oracle",
        description="Test the paper's claim that a smooth, low-volatility reference protects "
        "the grasp: the same object and subjects, references from each estimator (free run by "
        "default) and the oracle; prints volatility, estimation and tracking error, slip, drop "
        "and crush side by side.",
    )
    p.add_argument("--object", default="can", metavar="NAME",
                   help=f"{', '.join(object_names())} (default can)")
    p.add_argument("--mass-kg", type=float, default=None, help="override the object's mass, kg")
    p.add_argument("--friction", type=float, default=None, help="override the friction coeff.")
    p.add_argument("--estimators", default=",".join(DEFAULT_REFERENCES), metavar="LIST",
                   help=f"comma-separated, from {', '.join(estimator_choices())} "
                   f"(default {','.join(DEFAULT_REFERENCES)})")
    p.add_argument("--mode", default="free_run", metavar="MODE",
                   help="estimator mode: free_run (default) or one_step")
    p.add_argument("--controller", default="pid", metavar="NAME",
                   help=f"{', '.join(controller_names())} (default pid)")
    p.add_argument("--subjects", type=int, default=3, help="number of subjects (default 3)")
    p.add_argument("--seed", type=int, default=0,
                   help="the run's seed: each subject's sessions derive from it (default 0)")
    p.add_argument("--sessions", type=int, default=1, metavar="K",
                   help="independent sessions per subject (default 1)")
    p.add_argument("--practice", type=int, default=5, metavar="N",
                   help="practice lifts before each trial, 0..50 (default 5; 0 is the novice)")
    add_user_options(p)
    add_hand_options(p, paradigm_list=True)
    p.add_argument("--json", type=Path, default=None, metavar="FILE", help="write results here")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop compare-references``; returns the exit status."""
    names = [n.strip() for n in args.estimators.split(",") if n.strip()]
    choices = estimator_choices()
    unknown = [n for n in names if n not in choices]
    if unknown or not names:
        raise UnknownChoiceError(f"--estimators: unknown {unknown or names}; expected names from "
                          f"{', '.join(choices)}")
    if args.mode not in ("free_run", "one_step"):
        raise UsageError(f"--mode: expected free_run or one_step, found {args.mode!r}")
    if args.subjects < 1:
        raise UsageError(f"--subjects: expected at least 1, found {args.subjects}")
    if args.sessions < 1:
        raise UsageError(f"--sessions: expected at least 1, found {args.sessions}")
    check_user_options(args.user, [args.feedback])
    check_practice_window(args.practice, 400.0, 125.0)
    paradigms = [p.strip() for p in args.paradigm.split(",") if p.strip()] or ["force"]
    check_hand_options(paradigms, args.drive)
    obj = object_for(args.object, mass_kg=args.mass_kg, friction=args.friction)
    by_paradigm = {p: compare_references(
        obj, EpisodeSpec(mode=args.mode, controller=args.controller, user=args.user,
                         feedback=args.feedback, practice=args.practice,
                         hand=HandSettings(args.drive, p, args.auto_grip)),
        estimators=names, subject_ids=range(1, args.subjects + 1), seed=args.seed,
        sessions=args.sessions) for p in paradigms}
    result = dict(by_paradigm[paradigms[0]])
    if len(paradigms) > 1:
        result["by_paradigm"] = by_paradigm
    print(f"{obj.name} ({obj.mass_kg:g} kg, mu {obj.friction:g}), {args.controller}, "
          f"{args.subjects} subjects x {args.sessions} sessions (seeds from {args.seed} and the "
          f"subject), {args.user} user, feedback {args.feedback}, practice {args.practice}, "
          f"{args.drive} drive{', auto-grip' if args.auto_grip else ''}")
    for paradigm, entry in by_paradigm.items():
        if len(paradigms) > 1:
            print(f"paradigm {paradigm}:")
        print(format_comparison(entry))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1, default=float))
        print(f"wrote {args.json}")
    return 0
