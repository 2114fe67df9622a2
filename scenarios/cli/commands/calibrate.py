"""``griploop calibrate``: record the paper's calibration session from a live person."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from scenarios.cli.errors import UsageError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` subcommand."""
    p = subparsers.add_parser(
        "calibrate",
        help="record the paper's calibration session from a live sEMG stream (LSL)",
        description="Record the paper's calibration session from a person: cues (rest, squeeze "
        "small, medium, strong, each followed by a rest) are printed in the terminal as the "
        "stream reaches them, paced by the sEMG samples. The force comes from an LSL force "
        "stream if one exists (NAME.force, or the only stream of type Force), else from the "
        "level each cue asks for times --mvc-n. The file is a recording griploop evaluate and "
        "griploop live --calibration accept.",
    )
    p.add_argument("--lsl", required=True, metavar="NAME", help="name of the sEMG LSL stream")
    p.add_argument("--out", required=True, type=Path, metavar="CAL.npz",
                   help="where to write the recording (.npz or .csv)")
    p.add_argument("--force-lsl", default=None, metavar="NAME",
                   help="name of the force stream (N); default: NAME.force or the only Force "
                   "stream; 'none' labels by the cues")
    p.add_argument("--mvc-n", type=float, default=40.0,
                   help="without a force stream: the label of a 100 %% squeeze, N (default 40)")
    p.add_argument("--squeeze-s", type=float, default=4.0,
                   help="how long each squeeze is held, s (default 4)")
    p.add_argument("--rest-s", type=float, default=4.0,
                   help="rest after each squeeze, s (default 4; 3 s before the first, 5 s "
                   "after the last)")
    p.add_argument("--timeout-s", type=float, default=5.0,
                   help="give up when no sample arrives for this long, s (default 5)")
    p.add_argument("--resolve-timeout-s", type=float, default=5.0,
                   help="how long to look for the stream, s (default 5)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop calibrate``; returns the exit status."""
    from scenarios.live import lsl
    from scenarios.live.calibrate import cue_schedule, record_calibration

    if args.out.suffix not in (".npz", ".csv"):
        raise UsageError(f"--out: expected a .npz or .csv file, found {args.out.name!r}")
    for flag, value in (("--mvc-n", args.mvc_n), ("--squeeze-s", args.squeeze_s),
                        ("--rest-s", args.rest_s), ("--timeout-s", args.timeout_s),
                        ("--resolve-timeout-s", args.resolve_timeout_s)):
        if not (math.isfinite(value) and value > 0):
            raise UsageError(f"{flag}: expected a positive number, found {value}")
    lsl.pylsl_module()
    cues, duration_s = cue_schedule(squeeze_s=args.squeeze_s, rest_s=args.rest_s)
    info = lsl.resolve(args.lsl, args.resolve_timeout_s)
    force_info = None
    if args.force_lsl is None:
        force_info = lsl.find_force_stream(args.lsl, min(1.0, args.resolve_timeout_s))
    elif args.force_lsl.strip().lower() != "none":
        force_info = lsl.resolve(args.force_lsl, args.resolve_timeout_s, what="force stream")
    if force_info is not None and force_info.channel_count() != 1:
        raise UsageError(f"--force-lsl: expected a 1-channel force stream, found "
                         f"{lsl.describe(force_info)}")
    force_text = (f"force from {lsl.describe(force_info)}" if force_info is not None else
                  f"no force stream: the force label is each cue's level x {args.mvc_n:g} N")
    print(f"calibrate: {duration_s:g} s session on {lsl.describe(info)}; {force_text}",
          flush=True)
    # the force inlet first, so that it misses none of the samples the sEMG's start releases
    force_inlet = (lsl.open_inlet(force_info, prime_clock=False) if force_info is not None
                   else None)
    inlet = lsl.open_inlet(info, prime_clock=False)
    recording = record_calibration(
        inlet, force_inlet, cues=cues, duration_s=duration_s,
        say=lambda line: print(line, flush=True), mvc_n=args.mvc_n, timeout_s=args.timeout_s,
        source=str(args.out), stream_name=info.name(),
        force_name=None if force_info is None else force_info.name())
    args.out.parent.mkdir(parents=True, exist_ok=True)
    recording.save(args.out)
    print(f"recorded {recording.n_samples} samples ({recording.duration_s:.1f} s, "
          f"{recording.metadata['lost_samples']} lost), peak force "
          f"{float(recording.force_n.max()):.1f} N -> {args.out}")
    print(f"next: griploop evaluate --recording {args.out}   or   griploop live --lsl "
          f"{args.lsl} --calibration {args.out} --controller pid --object can")
    return 0
