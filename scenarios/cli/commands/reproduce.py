"""``griploop reproduce``: the paper's Tables 2 and 3 on virtual subjects."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from estimation.reproduce import ScoreSettings, format_report, parse_channels, write_csv
from scenarios.cli.choices import generator_names


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, found {text}")
    return value


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``reproduce`` subcommand."""
    parser = subparsers.add_parser(
        "reproduce",
        help="reproduce the paper's Tables 2 and 3 on virtual subjects",
        description="Simulate the paper's squeeze session for N virtual subjects, identify "
        "on the first 50 % of each, validate on the rest, and print Table 2 (R2, NRMSE per "
        "subject) for one_step and free_run and Table 3 (timing, system properties) next "
        "to the paper's numbers.",
    )
    parser.add_argument("--subjects", type=_positive_int, default=10,
                        help="number of virtual subjects (default: 10)")
    parser.add_argument("--seed", type=int, default=0, help="population and session seed")
    parser.add_argument("--generator", choices=generator_names(), default="noise",
                        help="virtual subjects' sEMG model (default: noise)")
    parser.add_argument("--order", type=_positive_int, default=4,
                        help="state-space order used for the tables (default: 4, the paper's)")
    parser.add_argument("--max-epochs", type=_positive_int, default=1000,
                        help="MLP/NARX epoch limit (default: 1000, the paper's)")
    parser.add_argument("--channels", default="6,7,8",
                        help="sEMG channels: 'all' or comma-separated 1-based numbers "
                        "(default: 6,7,8, the paper's)")
    parser.add_argument("--workers", type=_positive_int, default=1,
                        help="subjects evaluated at once, each in its own process (default: "
                        "1); the figures do not depend on it")
    parser.add_argument("--judge", default="wide", metavar="VARIANT",
                        help="population variant the estimators that learn from virtual "
                        "subjects are judged on, with the other sEMG generator (default: "
                        "wide; 'none': not judged, and not recommended)")
    parser.add_argument("--inner", action="store_true",
                        help="also score the inner split of each identification half and "
                        "compare choosing per person on it with the real recordings")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    parser.add_argument("--csv", metavar="DIR", help="write the tables as CSV files")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    from scenarios.runners.reproduction import ReproductionAnalyses, run_reproduction

    t0 = time.perf_counter()
    settings = ScoreSettings(parse_channels(args.channels), args.order,
                             {"max_epochs": args.max_epochs})
    analyses = ReproductionAnalyses(judge=None if args.judge == "none" else args.judge,
                                    inner=args.inner)
    result = run_reproduction(args.subjects, args.seed, settings=settings,
                              generator=args.generator, analyses=analyses,
                              workers=args.workers)
    result["config"]["wall_time_s"] = time.perf_counter() - t0
    print(format_report(result))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {args.json}")
    if args.csv:
        for path in write_csv(result, args.csv):
            print(f"wrote {path}")
    print(f"({args.subjects} subjects in {result['config']['wall_time_s']:.1f} s)")
    return 0
