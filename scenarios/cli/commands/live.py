"""``griploop live``: a person's sEMG over LSL drives the simulated hand in real time, and
their own arm (the armband's IMU, or a key) moves the wrist."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

from scenarios.cli.choices import (
    add_hand_options,
    check_hand_options,
    controller_names,
    object_names,
    one_of,
)
from scenarios.cli.errors import UsageError
from scenarios.cli.lsl_options import add_stream_options, resolve_pinned, stream_query
from scenarios.cli.recording_options import add_recording_options, load_with_options
from sim.user.feedback import FeedbackDevice

DEFAULT_ESTIMATOR = "ridge"


def _free_run_estimators() -> list[str]:
    from estimation.registry import estimator_info, estimator_names

    return [n for n in estimator_names() if "free_run" in estimator_info(n)["modes"]]


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``live`` subcommand."""
    p = subparsers.add_parser(
        "live",
        help="drive the simulated hand in real time from a live sEMG stream (LSL)",
        description="Resolve one sEMG stream (refused when several match, or when it comes from "
        "another host without --allow-remote), check its channel count and rate against the "
        "calibration recording, fit the estimator on that recording, then run windowing, "
        "features, estimate, controller and the MuJoCo hand in real time, paced by the incoming "
        "samples, for one grasp-lift-hold, judged as every trial is (a lift that leaves the "
        "object behind is an attempt: the session goes on). The wrist follows the person: the "
        "forearm's pitch on the armband's IMU stream (--imu-lsl), mapped to the wrist's height by "
        "the arm poses of the calibration recording, or else the Enter key (lift / put down). The "
        "session keeps its streams' sources: another source taking over a name ends it with the "
        "hand holding its grip. Publishes griploop.reference, griploop.grip and griploop.events "
        "as LSL outlets. Shows the hand in the MuJoCo viewer when a display exists, else writes a "
        "GIF of the session. Prints the timing report (samples received and lost, latency from "
        "sample arrival to motor command, deadlines missed, physics real-time factor) and the "
        "episode's metrics; docs/FORMAT.md describes the JSON, docs/LIVE.md a lab's session.",
    )
    add_stream_options(p, imu_help="the armband's orientation stream (a channel labelled pitch, "
                       "or a quaternion qw, qx, qy, qz): the wrist follows the forearm's pitch; "
                       "without it, Enter lifts the wrist and Enter again puts it down")
    p.add_argument("--arm-poses", default=None, metavar="REST_DEG:RAISED_DEG",
                   help="the forearm's pitch at rest (hand at the object) and raised as for a "
                   "lift, degrees (default: the calibration recording's arm_poses, which "
                   "griploop calibrate records with an IMU stream)")
    add_hand_options(p)
    p.add_argument("--calibration", required=True, metavar="CAL",
                   help="calibration recording of the same person and armband (.npz or .csv, "
                   "with force): griploop calibrate --lsl writes one; --paradigm velocity and "
                   "--decoder need one with open contractions (griploop calibrate --open)")
    p.add_argument("--estimator", default=DEFAULT_ESTIMATOR, metavar="NAME",
                   help=f"{one_of(_free_run_estimators())} (default: {DEFAULT_ESTIMATOR}; "
                   "run in free_run: sEMG only)")
    p.add_argument("--channels", default="6,7,8",
                   help="'all', or comma-separated channels as 1-based numbers or names "
                   "(default: 6,7,8)")
    p.add_argument("--controller", required=True, metavar="NAME", help=one_of(controller_names()))
    p.add_argument("--object", required=True, metavar="NAME", help=one_of(object_names()))
    p.add_argument("--feedback", default="none", choices=FeedbackDevice.MODES, metavar="MODE",
                   help="also publish griploop.feedback, the stimulator's intensity 0..1 for a "
                   "tactor driver: force_vibration (grip-force level) or slip_vibration (a "
                   "burst at each slip); " + one_of(FeedbackDevice.MODES) + " (default none)")
    p.add_argument("--mass-kg", type=float, default=None, help="override the object's mass, kg")
    p.add_argument("--friction", type=float, default=None, help="override the friction coeff.")
    p.add_argument("--duration-s", type=float, default=8.0,
                   help="session length in stream time, s (default 8)")
    p.add_argument("--json", type=Path, default=None, metavar="FILE",
                   help="also write the report as JSON here")
    p.add_argument("--record", type=Path, default=None, metavar="FILE.npz",
                   help="also save the sEMG received as a recording (.npz or .csv)")
    p.add_argument("--video", type=Path, default=None, metavar="FILE.gif",
                   help="GIF of the session (default without a display: FILE.gif beside --json, "
                   "else griploop-live.gif)")
    p.add_argument("--no-video", action="store_true", help="write no GIF")
    p.add_argument("--no-viewer", action="store_true",
                   help="do not open the MuJoCo viewer even if a display exists")
    p.add_argument("--timeout-s", type=float, default=5.0,
                   help="end the session when no sample arrives for this long, s (default 5)")
    p.add_argument("--resolve-timeout-s", type=float, default=5.0,
                   help="how long to look for the streams, s (default 5; once every stream "
                   "asked for has appeared, 1 s more for others of the same names)")
    p.add_argument("--outlet-prefix", default="griploop", metavar="PREFIX",
                   help="name prefix of the session's outlets (default griploop: "
                   "griploop.reference, griploop.grip, griploop.events)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the estimators that draw random numbers (default 0)")
    add_recording_options(p)
    p.set_defaults(func=run)


def _check(args: argparse.Namespace) -> None:
    from scenarios.cli.choices import check_choice

    check_choice("--estimator", args.estimator, _free_run_estimators())
    check_choice("--controller", args.controller, controller_names())
    check_choice("--object", args.object, object_names())
    check_hand_options([args.paradigm], args.drive, args.decoder)
    for flag, value in (("--duration-s", args.duration_s), ("--timeout-s", args.timeout_s),
                        ("--resolve-timeout-s", args.resolve_timeout_s)):
        if not (math.isfinite(value) and value > 0):
            raise UsageError(f"{flag}: expected a positive number of seconds, found {value}")
    if args.video is not None and args.video.suffix.lower() != ".gif":
        raise UsageError(f"--video: expected a .gif file, found {args.video.name!r}")
    if args.record is not None and args.record.suffix not in (".npz", ".csv"):
        raise UsageError(f"--record: expected a .npz or .csv file, found {args.record.name!r}")
    if not args.outlet_prefix.strip() or any(c.isspace() for c in args.outlet_prefix):
        raise UsageError(f"--outlet-prefix: expected a name without spaces, found "
                         f"{args.outlet_prefix!r}")
    if args.arm_poses is not None and args.imu_lsl is None:
        raise UsageError("--arm-poses: maps the IMU's pitch, expected with --imu-lsl")
    if args.imu_source_id is not None and args.imu_lsl is None:
        raise UsageError("--imu-source-id: expected with --imu-lsl NAME")


def checked_decoder(cal_recording: Any, hand: Any) -> str | None:
    """The decoder the calibration fits for ``hand`` (``None``: none), refused as
    ``--calibration``'s fault in one line when the recording has no open contractions.

    Raises
    ------
    UsageError
        A paradigm or decoder that needs open contractions, on a calibration without any.
    """
    from estimation.decoding import NoOpenContractionsError
    from scenarios.live.recorded import calibration_decoder

    try:
        return calibration_decoder(cal_recording, hand)
    except NoOpenContractionsError as exc:
        raise UsageError(f"--calibration {exc}") from None


def _arm_poses(args: argparse.Namespace, cal_recording: Any) -> Any:
    """The arm poses: ``--arm-poses``, else the calibration recording's.

    Raises
    ------
    UsageError
        A malformed ``--arm-poses``, or none anywhere.
    """
    from scenarios.live.arm import ArmPoses
    from scenarios.live.errors import ArmPosesError

    if args.arm_poses is not None:
        try:
            return ArmPoses.from_text(args.arm_poses)
        except ArmPosesError as exc:
            raise UsageError(f"--arm-poses: {exc}") from None
    poses = ArmPoses.from_metadata(cal_recording.metadata, cal_recording.source)
    if poses is None:
        raise UsageError(
            f"--imu-lsl: the calibration recording {cal_recording.source} has no arm poses "
            "(metadata arm_poses) to map the forearm's pitch to the wrist's height; expected "
            "a calibration recorded by griploop calibrate --lsl with the IMU stream, or "
            "--arm-poses REST_DEG:RAISED_DEG")
    return poses


def _open_imu(args: argparse.Namespace, info: Any, cal_recording: Any,
              lsl: Any) -> tuple[Any, Any]:
    """The IMU stream's open inlet and the arm that follows it.

    Raises
    ------
    ImuChannelError
        The stream has no orientation channel (one line naming its channels).
    """
    from scenarios.live.arm import OrientationChannels, PitchArm

    poses = _arm_poses(args, cal_recording)
    inlet = lsl.open_inlet(info)
    try:
        channels = OrientationChannels.of_inlet(inlet, stream=f"IMU stream {info.name()!r}")
    except BaseException:
        inlet.close_stream()
        raise
    return inlet, PitchArm(poses, channels, imu_fs_hz=info.nominal_srate())


def run(args: argparse.Namespace) -> int:
    """Run ``griploop live``; returns the exit status."""
    from estimation.reproduce import parse_channels
    from scenarios.live import lsl
    from scenarios.live.display import FRAME_DT_S, Viewer, has_display, render_states
    from scenarios.live.hooks import SessionHooks
    from scenarios.live.inlets import run_session
    from scenarios.live.recorded import fit_calibration
    from scenarios.live.session import LiveGrasp, SessionSettings
    from scenarios.runners.trial_loop import HandSettings
    from sim.hand.objects import make_object

    _check(args)
    lsl.pylsl_module()  # one line with the fix if liblsl cannot load, before any work
    query = stream_query(args, "lsl")
    if args.imu_lsl is not None:
        stream_query(args, "imu")  # its form, before any work
    cal_recording = load_with_options(args.calibration, args)
    hand = HandSettings(args.drive, args.paradigm, args.auto_grip, args.decoder)
    decoder = checked_decoder(cal_recording, hand)
    if args.imu_lsl is not None:
        _arm_poses(args, cal_recording)
    cal = fit_calibration(cal_recording, args.estimator, channels=parse_channels(args.channels),
                          seed=args.seed, decoder=decoder)
    overrides = {k: v for k, v in (("mass_kg", args.mass_kg), ("friction", args.friction))
                 if v is not None}
    obj = make_object(args.object, **overrides)
    viewer_wanted = has_display() and not args.no_viewer
    video = None if args.no_video else args.video
    if video is None and not args.no_video and not viewer_wanted:
        video = (args.json.with_suffix(".gif") if args.json is not None
                 else Path("griploop-live.gif"))
    settings = SessionSettings(duration_s=args.duration_s, timeout_s=args.timeout_s,
                               frame_dt_s=FRAME_DT_S if video is not None else None,
                               hand=hand, feedback=args.feedback)
    wanted = [(query, "lsl", "stream")]
    if args.imu_lsl is not None:
        wanted.append((stream_query(args, "imu"), "imu", "IMU stream"))
    info, *rest = resolve_pinned(wanted, args.resolve_timeout_s)
    lsl.check_stream(info, n_channels=cal.n_channels, fs_hz=cal.fs_hz,
                     source=cal_recording.source)
    imu_info = rest[0] if rest else None
    imu_inlet, arm, arm_text = _arm(args, imu_info, cal_recording, lsl)
    outlets = lsl.SessionOutlets(1.0 / settings.control_dt_s, prefix=args.outlet_prefix,
                                 feedback=None if args.feedback == "none" else args.feedback)
    grasp: LiveGrasp | None = None

    def publish(t_s: float, reference_n: float, grip_n: float, feedback: float) -> None:
        outlets.step(grasp.ts0 + t_s, reference_n, grip_n, feedback)

    def event(t_s: float, marker: str) -> None:
        outlets.event(grasp.ts0 + t_s, marker)

    def notify(line: str) -> None:
        print(f"live: {line}", flush=True)

    grasp = LiveGrasp(cal, obj, arm=arm, controller=args.controller, settings=settings,
                      hooks=SessionHooks(publish, event, notify))
    watches = [("emg", lsl.SourceWatch(info))]
    if imu_info is not None:
        watches.append(("imu", lsl.SourceWatch(imu_info)))
    viewer = Viewer.open(grasp.env) if viewer_wanted else None
    grasp.viewer = viewer
    if viewer_wanted and viewer is None and video is None and not args.no_video:
        video = Path("griploop-live.gif")
        grasp.keep_frames(FRAME_DT_S)
    print(f"live: {args.estimator} (free_run, calibration R2 {cal.calibration.r2:.3f}) -> "
          f"{args.controller} on {obj.name} ({obj.mass_kg:g} kg, mu {obj.friction:g}), "
          f"paradigm {args.paradigm}"
          f"{'' if decoder is None else f' ({decoder} decoder)'}, {args.drive} drive"
          f"{', auto-grip' if args.auto_grip else ''}; "
          f"stream {lsl.describe(info)} from {lsl.source_of(info)}; "
          f"{arm_text}; outlets {', '.join(outlets.names)}", flush=True)
    try:
        run_session(grasp, lambda: lsl.open_inlet(info), imu=imu_inlet, watches=watches)
    except KeyboardInterrupt:
        _finish(args, grasp, info, imu_info, outlets, lsl)
        raise
    finally:
        if viewer is not None:
            viewer.close()
    report = _finish(args, grasp, info, imu_info, outlets, lsl)
    if video is not None and grasp.frames:
        render_states(obj, grasp.frames, video)
        print(f"wrote {video}")
    if grasp.ended == "diverged":
        from scenarios.runners.dispatch import DivergedError

        raise DivergedError(f"physics diverged at t = {report['session_s']:.3f} s: "
                            f"{grasp.failure}")
    return 0


def _arm(args: argparse.Namespace, imu_info: Any, cal_recording: Any,
         lsl: Any) -> tuple[Any, Any, str]:
    """The IMU inlet (or ``None``), the arm that moves the wrist, and how, for the banner."""
    import sys

    from scenarios.live.arm import KeyArm, LineKeys

    if imu_info is not None:
        imu_inlet, arm = _open_imu(args, imu_info, cal_recording, lsl)
        return imu_inlet, arm, (
            f"the wrist follows the forearm's pitch on {lsl.describe(imu_info)} "
            f"({arm.channels.kind} {', '.join(arm.channels.labels)}; rest "
            f"{math.degrees(arm.poses.rest_pitch_rad):.1f} deg, raised "
            f"{math.degrees(arm.poses.raised_pitch_rad):.1f} deg = "
            f"{100 * arm.poses.lift_height_m:g} cm)")
    keys = LineKeys(sys.stdin)
    arm = KeyArm(keys.presses, closed=lambda: keys.closed)
    return None, arm, ("no --imu-lsl: press Enter to lift the wrist, Enter again to put it "
                       "down" + ("" if sys.stdin.isatty() else " (each line read from stdin)"))


def _finish(args: argparse.Namespace, grasp: Any, info: Any, imu_info: Any, outlets: Any,
            lsl: Any) -> dict[str, Any]:
    """Report, print, and write the JSON and the recording (the calibration and the object
    are the session's: ``grasp.cal``, ``grasp.obj``)."""
    cal, obj = grasp.cal, grasp.obj
    report = grasp.report()
    report.update({
        "stream": lsl.identity(info),
        "imu_stream": None if imu_info is None else lsl.identity(imu_info),
        "calibration": cal.summary(),
        "controller": args.controller,
        "object": {"name": obj.name, "mass_kg": obj.mass_kg, "friction": obj.friction,
                   "break_force_n": obj.break_force_n},
        "outlets": list(outlets.names),
    })
    print(format_report(report))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=1) + "\n")
        print(f"wrote {args.json}")
    if args.record is not None and grasp.received:
        rec = grasp.recording(str(args.record), {"stream": report["stream"],
                                                 "imu_stream": report["imu_stream"],
                                                 "calibration": report["calibration"],
                                                 "metrics": report["metrics"],
                                                 "ended": report["ended"]})
        args.record.parent.mkdir(parents=True, exist_ok=True)
        rec.save(args.record)
        print(f"wrote {args.record}")
    outlets.close()
    return report


def _arm_line(arm: dict[str, Any]) -> str:
    lift = arm.get("lift_start_s")
    text = (f"{arm['source']}: " + ("never lifted" if lift is None else
                                    f"lift started at {lift:.2f} s"))
    if arm["source"] == "imu":
        stalls = ", ".join(f"at {g['t_s']:.2f} s for {g['duration_s']:.2f} s"
                           for g in arm["imu_gaps"])
        text += f"; {arm['imu_samples']} IMU samples, stalls: {stalls or 'none'}"
    else:
        text += f"; {arm['presses']} key presses"
    return text


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f} ms"


def format_report(report: dict[str, Any]) -> str:
    """The timing report and the grasp's metrics, as printed."""
    s, m = report["samples"], report["metrics"]
    rtf = report["realtime_factor"]["physics"]
    gaps = ", ".join(f"at {g['t_s']:.2f} s for {g['duration_s']:.2f} s" for g in report["gaps"])
    bad = report["bad_samples"]
    peak = m.get("peak_force_n")
    hold = m.get("hold_grip_n")
    lines = [
        f"  {'samples':<18} {s['received']} received of {s['expected']} expected, "
        f"{s['lost']} lost",
        f"  {'latency':<18} p50 {_ms(report['latency_ms']['p50'])}, p99 "
        f"{_ms(report['latency_ms']['p99'])}, max {_ms(report['latency_max_ms'])} "
        "(sample arrival to motor command)",
        f"  {'deadlines missed':<18} {report['deadline_misses']} of {report['control_steps']} "
        f"control steps ({1e3 * report['control_dt_s']:g} ms period)",
        f"  {'LSL transport':<18} p50 {_ms(report['transport_ms']['p50'])}, p99 "
        f"{_ms(report['transport_ms']['p99'])} (time stamp to arrival)",
        f"  {'physics':<18} " + ("-" if rtf is None else f"{rtf:.1f}x real time"),
        f"  {'gaps':<18} {gaps or 'none'}",
        f"  {'bad samples':<18} {bad['non_numeric']} non-numeric, {bad['out_of_range']} out of "
        "range (replaced by 0 / clipped)",
        f"  {'outcome':<18} {m.get('outcome')}; peak "
        + ("-" if peak is None else f"{peak:.2f} N")
        + ", hold grip " + ("-" if hold is None else f"{hold:.2f} N")
        + f", slip events {m.get('slip_events')}",
        f"  {'arm':<18} {_arm_line(report['arm'])}",
        f"  {'ended':<18} {report['ended']} after {report['session_s']:.2f} s of session time",
    ]
    lines += [f"  {'source changed':<18} at {c['t_s']:.2f} s: {c['stream']} stream "
              f"{c['found']['name']!r} now from source_id {c['found']['source_id']!r} on host "
              f"{c['found']['host']!r}" for c in report["source_changes"]]
    lines += [f"warning: {w}" for w in report["warnings"]]
    return "\n".join(lines)
