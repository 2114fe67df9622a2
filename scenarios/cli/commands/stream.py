"""``griploop stream``: play a recording as a Lab Streaming Layer outlet."""

from __future__ import annotations

import argparse

from scenarios.cli.errors import UsageError
from scenarios.cli.recording_options import add_recording_options, load_with_options


def _dropout(text: str) -> tuple[float, float]:
    try:
        at, duration = (float(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected AT_S:DURATION_S such as 6.2:1.0, found {text!r}") from None
    if at < 0 or duration <= 0:
        raise argparse.ArgumentTypeError(
            f"expected AT_S >= 0 and DURATION_S > 0, found {text!r}")
    return at, duration


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``stream`` subcommand."""
    p = subparsers.add_parser(
        "stream",
        help="play a recording as a Lab Streaming Layer (LSL) sEMG stream",
        description="Publish a recording (any format griploop evaluate reads) as an LSL outlet "
        "at its own rate, with the channel count, rate and format of the recording (int8 for "
        "MYO counts, else float32), its force, if it has one, as NAME.force, and its forearm "
        "pitch, if it has one, as NAME.imu (the armband's orientation quaternion qw, qx, qy, "
        "qz at 50 Hz). Every outlet has a source_id of its own (printed), so two players of "
        "one name are told apart. Playing starts when a consumer connects (griploop live, "
        "griploop calibrate, LabRecorder). For demos and tests, and to replay a lab's session.",
    )
    p.add_argument("file", metavar="FILE", help="recording (.npz or .csv)")
    p.add_argument("--name", default="griploop.emg",
                   help="LSL stream name (default: griploop.emg)")
    p.add_argument("--loop", action="store_true", help="start again at the end, until stopped")
    p.add_argument("--speed", type=float, default=1.0,
                   help="play this many times faster than real time (default 1; time stamps "
                   "follow)")
    p.add_argument("--dropout", type=_dropout, action="append", default=[], metavar="AT:DUR",
                   help="send nothing from AT s for DUR s of stream time (samples in between "
                   "are lost, as in a wireless dropout); repeatable")
    p.add_argument("--imu-dropout", type=_dropout, action="append", default=[],
                   metavar="AT:DUR",
                   help="send no orientation from AT s for DUR s of stream time (the IMU stream "
                   "stalls, the sEMG goes on); repeatable")
    p.add_argument("--no-imu", action="store_true",
                   help="do not publish the recording's forearm pitch as NAME.imu")
    p.add_argument("--stop-after-s", type=float, default=None, metavar="S",
                   help="stop after S s of stream time and withdraw the outlets (a streamer "
                   "that goes away)")
    p.add_argument("--no-wait", action="store_true",
                   help="start playing at once instead of waiting for a consumer")
    add_recording_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop stream``; returns the exit status."""
    from scenarios.live.lsl import pylsl_module
    from scenarios.live.player import Dropout, Playback, play

    if not args.speed > 0:
        raise UsageError(f"--speed: expected a positive factor, found {args.speed}")
    if not args.name.strip():
        raise UsageError("--name: expected a stream name, found an empty one")
    if args.stop_after_s is not None and not args.stop_after_s > 0:
        raise UsageError(f"--stop-after-s: expected a positive number of seconds, found "
                         f"{args.stop_after_s}")
    pylsl_module()
    recording = load_with_options(args.file, args)
    if args.imu_dropout and (recording.pitch_rad is None or args.no_imu):
        raise UsageError(f"--imu-dropout: {recording.source} has no forearm pitch to stream "
                         "(no pitch_rad)" if not args.no_imu else
                         "--imu-dropout: expected without --no-imu")
    playback = Playback(loop=args.loop, speed=args.speed, imu=not args.no_imu,
                        wait_for_consumer=not args.no_wait,
                        dropouts=tuple(Dropout(a, d) for a, d in args.dropout),
                        imu_dropouts=tuple(Dropout(a, d) for a, d in args.imu_dropout),
                        stop_after_s=args.stop_after_s)
    play(recording, args.name, playback, log=lambda line: print(line, flush=True))
    return 0
