"""``griploop evaluate``: the paper's protocol on one recording file."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from estimation.registry import estimator_names
from estimation.reproduce import evaluate_recording, format_summary, parse_channels
from scenarios.cli.recording_options import add_recording_options, load_with_options
from sim.recording import RecordingError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``evaluate`` subcommand."""
    parser = subparsers.add_parser(
        "evaluate",
        help="fit and score every force estimator on one recording",
        description="Extract MAV/RMS/WL features of the chosen channels, identify on the "
        "first 50 %% of the windows, validate on the rest and report R2, NRMSE, RMSE and "
        "timings per estimator and mode (one_step uses the measured force up to k-1, "
        "free_run sEMG only). CSV files from other tools are read through the layout options "
        "below (column names, time unit, resampling); docs/FORMAT.md has examples.",
    )
    parser.add_argument("--recording", required=True, metavar="FILE",
                        help="recording (.npz or .csv) with sEMG and measured force")
    add_recording_options(parser)
    parser.add_argument("--channels", default="6,7,8",
                        help="'all', or comma-separated channels as 1-based numbers or "
                        "names (default: 6,7,8)")
    parser.add_argument("--estimators", default=",".join(estimator_names()),
                        help="comma-separated estimator names (default: all)")
    parser.add_argument("--order", type=int, default=4, help="state-space order (default: 4)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the networks")
    parser.add_argument("--json", metavar="FILE",
                        help="also write the results as JSON (the table is printed either way)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    recording = load_with_options(args.recording, args)
    layout = recording.metadata.get("csv_layout", {})
    ignored = layout.get("ignored", []) if isinstance(layout, dict) else []
    if recording.force_n is None:
        unused = f" (unused columns: {', '.join(map(repr, ignored[:8]))})" if ignored else ""
        raise RecordingError(
            f"{recording.source}: no force column; the protocol needs the measured force: "
            f"pass --force-column NAME{unused}"
        )
    if ignored:
        print(f"{recording.source}: ignored columns {', '.join(map(repr, ignored[:12]))}"
              + (" ..." if len(ignored) > 12 else ""))
    names = [t.strip() for t in args.estimators.split(",") if t.strip()]
    result = evaluate_recording(recording, channels=parse_channels(args.channels), estimators=names,
                                order=args.order, seed=args.seed)
    print(format_summary(result))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0
