"""``griploop calibrate``: record the paper's calibration session from a live person (and,
with ``--open``, open contractions after it)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from scenarios.cli.errors import UsageError
from scenarios.cli.lsl_options import add_stream_options, resolve_pinned, stream_query
from scenarios.live.errors import StreamSpecError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` subcommand."""
    p = subparsers.add_parser(
        "calibrate",
        help="record the paper's calibration session from a live sEMG stream (LSL)",
        description="Record the paper's calibration session from a person: cues (rest, squeeze "
        "small, medium, strong, each followed by a rest) are printed in the terminal as the "
        "stream reaches them, paced by the sEMG samples. The force comes from an LSL force "
        "stream if one exists (NAME.force, or the only stream of type Force), else from the "
        "level each cue asks for times --mvc-n. With the armband's IMU stream (NAME.imu, or "
        "--imu-lsl), the forearm's pitch is recorded beside the sEMG and two arm poses are "
        "asked for after the squeezes (at rest, raised as for a lift): griploop live maps the "
        "pitch to the wrist's height with them. With --open, open contractions follow the "
        "squeezes (open small, medium, strong: 30, 60 and 100 % of the person's widest "
        "opening, each held --squeeze-s and followed by --rest-s), labelled open_intent from "
        "the cues: an open/close decoder is fitted on them (griploop live --paradigm velocity "
        "needs it). The file is a recording griploop evaluate and griploop live --calibration "
        "accept.",
    )
    add_stream_options(p, imu_help="the armband's orientation stream, recorded with the arm "
                       "poses (default: NAME.imu when there is one, on --lsl's host if given; "
                       "'none': no IMU)")
    p.add_argument("--out", required=True, type=Path, metavar="CAL.npz",
                   help="where to write the recording (.npz or .csv)")
    p.add_argument("--force-lsl", default=None, metavar="NAME",
                   help="name of the force stream (N); default: NAME.force or the only Force "
                   "stream; 'none' labels by the cues")
    p.add_argument("--mvc-n", type=float, default=40.0,
                   help="without a force stream: the label of a 100 %% squeeze, N (default 40)")
    p.add_argument("--open", action="store_true",
                   help="after the squeezes, cue three open contractions (open small, medium, "
                   "strong) and label them open_intent: a calibration for --paradigm velocity "
                   "and --decoder (24 s more by default)")
    p.add_argument("--squeeze-s", type=float, default=4.0,
                   help="how long each squeeze (and open contraction) is held, s (default 4)")
    p.add_argument("--rest-s", type=float, default=4.0,
                   help="rest after each squeeze, s (default 4; 3 s before the first, 5 s "
                   "after the last)")
    p.add_argument("--timeout-s", type=float, default=5.0,
                   help="give up when no sample arrives for this long, s (default 5)")
    p.add_argument("--resolve-timeout-s", type=float, default=5.0,
                   help="how long to look for the streams, s (default 5; once every stream "
                   "asked for has appeared, 1 s more for others of the same names)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop calibrate``; returns the exit status."""
    from scenarios.live import lsl
    from scenarios.live.calibrate import (
        OPEN_LEVELS,
        CalibrationStreams,
        cue_schedule,
        record_calibration,
    )

    if args.out.suffix not in (".npz", ".csv"):
        raise UsageError(f"--out: expected a .npz or .csv file, found {args.out.name!r}")
    for flag, value in (("--mvc-n", args.mvc_n), ("--squeeze-s", args.squeeze_s),
                        ("--rest-s", args.rest_s), ("--timeout-s", args.timeout_s),
                        ("--resolve-timeout-s", args.resolve_timeout_s)):
        if not (math.isfinite(value) and value > 0):
            raise UsageError(f"{flag}: expected a positive number, found {value}")
    lsl.pylsl_module()
    query = stream_query(args, "lsl")
    no_imu = args.imu_lsl is not None and args.imu_lsl.strip().lower() == "none"
    if args.imu_lsl is not None and not no_imu:
        stream_query(args, "imu")
    cues, duration_s = cue_schedule(squeeze_s=args.squeeze_s, rest_s=args.rest_s,
                                    open_levels=OPEN_LEVELS if args.open else ())
    # the sEMG and its IMU stream together: --imu-lsl, or NAME.imu if there is one
    wanted = [(query, "lsl", "stream")]
    optional = []
    if not no_imu:
        auto = args.imu_lsl is None  # NAME.imu (on --lsl's host if given), if there is one
        at = f"@{query.host}" if query.host else ""
        imu_query = stream_query(args, "imu", name=query.name + lsl.IMU_SUFFIX + at
                                 if auto else None)
        wanted.append((imu_query, "imu", "IMU stream"))
        if auto and args.imu_source_id is None:
            optional.append(imu_query.name)
    at = f"@{query.host}" if query.host else ""
    if args.force_lsl is None:  # NAME.force if there is one (else the only Force stream)
        force_query = lsl.StreamQuery.parse(query.name + lsl.FORCE_SUFFIX + at,
                                            allow_remote=args.allow_remote)
        optional.append(force_query.name)
    elif args.force_lsl.strip().lower() != "none":
        try:
            force_query = lsl.StreamQuery.parse(args.force_lsl, allow_remote=args.allow_remote)
        except StreamSpecError as exc:
            raise UsageError(f"--force-lsl: {exc}") from None
    else:
        force_query = None
    if force_query is not None:
        wanted.append((force_query, "force", "force stream"))
    info, *rest = resolve_pinned(wanted, args.resolve_timeout_s, optional=optional)
    imu_info = None if no_imu else rest.pop(0)
    force_info = rest.pop(0) if rest else None
    if args.force_lsl is None and force_info is None:
        force_info = lsl.find_force_stream(info.name(), min(1.0, args.resolve_timeout_s))
    if force_info is not None and force_info.channel_count() != 1:
        raise UsageError(f"--force-lsl: expected a 1-channel force stream, found "
                         f"{lsl.describe(force_info)}")
    force_text = (f"force from {lsl.describe(force_info)}" if force_info is not None else
                  f"no force stream: the force label is each cue's level x {args.mvc_n:g} N")
    imu_inlet = channels = None
    if imu_info is not None:
        imu_inlet, channels = _imu_inlet(imu_info, lsl)
        imu_text = (f"forearm pitch from {lsl.describe(imu_info)} ({channels.kind}), then two "
                    "arm poses")
    else:
        imu_text = "no IMU stream: no arm poses (griploop live will then need --arm-poses)"
    open_text = ("; then open contractions (open_intent from the cues)" if args.open else "")
    print(f"calibrate: {duration_s:g} s session on {lsl.describe(info)} from "
          f"{lsl.source_of(info)}; {force_text}; {imu_text}{open_text}", flush=True)
    # the force inlet first, so that it misses none of the samples the sEMG's start releases;
    # each inlet's clock offset is measured before it connects (the first pull would
    # otherwise wait for it while the player's samples queue: at --speed 16, beyond the
    # inlet's buffer)
    force_inlet = lsl.open_inlet(force_info) if force_info is not None else None
    inlet = lsl.open_inlet(info)
    streams = CalibrationStreams(
        inlet, force_inlet, stream_name=info.name(),
        force_name=None if force_info is None else force_info.name(),
        imu_inlet=imu_inlet, imu_channels=channels,
        imu_name=None if imu_info is None else imu_info.name(),
        stream_identity=lsl.identity(info))
    recording = record_calibration(
        streams, cues=cues, duration_s=duration_s, say=lambda line: print(line, flush=True),
        mvc_n=args.mvc_n, timeout_s=args.timeout_s, source=str(args.out))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    recording.save(args.out)
    poses = recording.metadata.get("arm_poses")
    pose_text = ("" if poses is None else
                 f", arm poses rest {math.degrees(poses['rest_pitch_rad']):.1f} deg, raised "
                 f"{math.degrees(poses['raised_pitch_rad']):.1f} deg")
    print(f"recorded {recording.n_samples} samples ({recording.duration_s:.1f} s, "
          f"{recording.metadata['lost_samples']} lost), peak force "
          f"{float(recording.force_n.max()):.1f} N{pose_text} -> {args.out}")
    imu_next = "" if imu_info is None else f" --imu-lsl {imu_info.name()}"
    velocity = " --paradigm velocity --drive self_locking" if args.open else ""
    print(f"next: griploop evaluate --recording {args.out}   or   griploop live --lsl "
          f"{args.lsl}{imu_next} --calibration {args.out} --controller pid --object can"
          f"{velocity}")
    return 0


def _imu_inlet(info: object, lsl: object) -> tuple[object, object]:
    """The open IMU inlet and its orientation channels (refused in one line without any)."""
    from scenarios.live.arm import OrientationChannels

    inlet = lsl.open_inlet(info)
    try:
        return inlet, OrientationChannels.of_inlet(inlet, stream=f"IMU stream {info.name()!r}")
    except BaseException:
        inlet.close_stream()
        raise
