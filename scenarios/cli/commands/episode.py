"""``griploop episode``: one closed-loop grasp from a virtual subject's sEMG."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from controllers.design import worst_case
from scenarios.cli.choices import (
    add_hand_options,
    add_practice_window_options,
    add_user_options,
    check_hand_options,
    check_practice_window,
    check_user_options,
    controller_names,
    estimator_choices,
    object_names,
    one_of,
)
from scenarios.cli.commands.margins import format_table
from scenarios.cli.errors import UsageError
from scenarios.runners.episode import PHASE_CODES, episode_from_scenario
from scenarios.runners.video import write_video
from scenarios.schema import parse_scenario

METRIC_KEYS = ("outcome", "attempts", "time_to_lift_s", "safety_margin_pct", "paradigm", "drive",
               "auto_grip", "decoder", "unrequested_opens", "decoder_windows", "user_corrections",
               "practice", "belief_gain", "belief_margin_pct", "tracking_rmse_n",
               "estimation_rmse_n",
               "hold_reference_n",
               "held_force_n", "overshoot_pct", "settling_time_s", "contact_peak_ratio",
               "slip_events", "slip_distance_m", "lifted", "dropped", "crushed", "peak_force_n",
               "reference_volatility_n_per_s", "cal_r2")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``episode`` subcommand."""
    p = subparsers.add_parser(
        "episode",
        help="run one closed-loop grasp-lift-hold episode from sEMG to the MuJoCo hand",
        description="Calibrate an estimator on a virtual subject's paper session, then let the "
        "subject grasp, lift and hold an object: sEMG -> features -> estimator -> reference -> "
        "controller -> hand. Prints the loop margins and the episode metrics.",
    )
    p.add_argument("--controller", required=True, metavar="NAME",
                   help=one_of(controller_names()))
    p.add_argument("--estimator", required=True, metavar="NAME",
                   help=one_of(estimator_choices()))
    p.add_argument("--mode", default="free_run", metavar="MODE",
                   help="free_run (sEMG only, default) or one_step (the user wears a force "
                   "sensor, as in the paper)")
    p.add_argument("--object", required=True, metavar="NAME",
                   help=one_of(object_names()))
    p.add_argument("--mass-kg", type=float, default=None, help="override the object's mass, kg")
    p.add_argument("--friction", type=float, default=None, help="override the friction coeff.")
    p.add_argument("--subject", type=int, default=1, help="subject number (default 1)")
    p.add_argument("--population-seed", type=int, default=0,
                   help="seed of the virtual population (default 0)")
    p.add_argument("--seed", type=int, default=0, help="episode seed (default 0)")
    p.add_argument("--episode-s", type=float, default=None,
                   help="the trial's time limit, s (default 15; the scripted user's episode: 6)")
    p.add_argument("--hold-s", type=float, default=2.0,
                   help="how long the object is held in the air, s (default 2)")
    add_user_options(p)
    add_practice_window_options(p)
    add_hand_options(p)
    p.add_argument("--json", type=Path, default=None, metavar="FILE", help="also write JSON here")
    p.add_argument("--compiled", action="store_true",
                   help="run the fitted estimator and the designed controller as C compiled on "
                   "this machine (docs/DEPLOY.md); the metrics are the same as without")
    p.add_argument("--video", type=Path, default=None, metavar="FILE",
                   help="also render the episode to an animated GIF (.gif)")
    p.add_argument("--recording", type=Path, default=None, metavar="FILE",
                   help="drive the episode with this recording's sEMG instead of a virtual "
                   "subject's (the offline counterpart of griploop live on the same file); "
                   "needs --calibration")
    p.add_argument("--calibration", type=Path, default=None, metavar="CAL",
                   help="with --recording: the calibration recording the estimator is fitted on")
    p.add_argument("--channels", default="6,7,8",
                   help="with --recording: 'all' or comma-separated channels (default: 6,7,8)")
    p.add_argument("--arm-poses", default=None, metavar="REST_DEG:RAISED_DEG",
                   help="with --recording: map its forearm pitch (pitch_rad) to the wrist's "
                   "height with these poses (default: the recording's own, the calibration "
                   "recording's, or a virtual subject's forearm); a recording without a pitch "
                   "lifts at episode_s - hold_s - 0.6 s once the grip is established")
    p.set_defaults(func=run)


def scenario_from_args(args: argparse.Namespace) -> Any:
    """The validated scenario the options describe."""
    obj: dict[str, Any] = {"name": args.object}
    if args.mass_kg is not None:
        obj["mass_kg"] = args.mass_kg
    if args.friction is not None:
        obj["friction"] = args.friction
    return parse_scenario({
        "kind": "episode", "seed": args.seed,
        "subject": {"population_seed": args.population_seed, "subject_id": args.subject},
        "protocol": {"name": "grasp_lift_hold", "episode_s": args.episode_s,
                     "hold_s": args.hold_s},
        "object": obj,
        "estimator": {"name": args.estimator, "mode": args.mode, "window_ms": args.window_ms,
                      "step_ms": args.step_ms},
        "controller": {"kind": args.controller},
        "user": {"kind": args.user, "feedback": args.feedback, "practice": args.practice},
        "hand": {"drive": args.drive}, "paradigm": args.paradigm, "auto_grip": args.auto_grip,
        **({} if args.decoder is None else {"decoder": args.decoder}),
    }, source="options")


def run(args: argparse.Namespace) -> int:
    """Run ``griploop episode``; returns the exit status."""
    if args.video is not None and args.video.suffix.lower() != ".gif":
        raise UsageError(f"--video: expected a .gif file, found {args.video.name!r}")
    check_user_options(args.user, [args.feedback])
    check_practice_window(args.practice, args.window_ms, args.step_ms)
    check_hand_options([args.paradigm], args.drive, args.decoder)
    if (args.recording is None) != (args.calibration is None):
        raise UsageError("--recording and --calibration go together; found only "
                         + ("--recording" if args.calibration is None else "--calibration"))
    if args.arm_poses is not None and args.recording is None:
        raise UsageError("--arm-poses: maps a recording's forearm pitch, expected with "
                         "--recording")
    if args.recording is not None:
        if args.compiled:
            raise UsageError("--compiled runs a virtual subject's episode; found --recording")
        return _run_recorded(args)
    scenario = scenario_from_args(args)
    result = episode_from_scenario(scenario, record_frames=args.video is not None,
                                   compiled=args.compiled)
    row, design = result.row, result.design
    visited = sorted(_visited(row))
    analyses = design.analyse_many(visited)
    print(format_table(args.controller, analyses, worst_case(analyses) if analyses else None))
    print(f"episode: {args.estimator} ({args.mode}) -> {args.controller} on {row['object_name']} "
          f"({row['object_mass_kg']:g} kg, mu {row['object_friction']:g}), {args.user} user, "
          f"feedback {args.feedback}, practice {row['practice']}; paradigm {row['paradigm']}, "
          f"{row['drive']} drive, auto-grip {'on' if row['auto_grip'] else 'off'}")
    for key in METRIC_KEYS:
        value = row[key]
        text = f"{value:.4g}" if isinstance(value, float) else str(value)
        print(f"  {key:<30} {text}")
    print(f"  {'real-time factor':<30} {row['realtime_factor']:.1f}x")
    held = design.analyse(row["held_force_n"]) if row["held_force_n"] is not None else None
    out = {
        "scenario": scenario.model_dump(mode="json"),
        "margins_at_held_force": None if held is None else held.to_dict(),
        "worst_over_visited": {k[len("worst_"):]: v for k, v in row.items()
                               if k.startswith("worst_")},
        "design": {"spec": design.spec, "plant_family": design.family.summary()},
        "metrics": {k: row[k] for k in METRIC_KEYS},
        "phase_codes": list(PHASE_CODES),
        "compiled": _compiled_digests(result) if args.compiled else None,
        "row": row,
        "traces": {k: np.asarray(v).tolist() for k, v in result.traces.items()
                   if k in ("t_s", "intent_n", "reference_n", "grip_force_n", "command",
                            "object_height_m", "slip_speed_m_s", "user_intent",
                            "wrist_height_m", "phase")},
    }
    if args.json is not None:
        _write_json(args.json, out)
    return _write_video(args, result)


RECORDED_KEYS = ("outcome", "attempts", "time_to_lift_s", "safety_margin_pct", "released",
                 "lifted", "dropped", "crushed", "peak_force_n", "hold_grip_n",
                 "hold_reference_n", "tracking_rmse_n", "overshoot_pct", "settling_time_s",
                 "contact_peak_ratio", "slip_events", "slip_distance_m",
                 "reference_volatility_n_per_s")


def _run_recorded(args: argparse.Namespace) -> int:
    """``episode --recording FILE --calibration CAL``: the offline episode on a given recording."""
    from estimation.reproduce import parse_channels
    from scenarios.cli.choices import check_choice
    from scenarios.cli.commands.live import checked_decoder
    from scenarios.live.arm import ArmPoses
    from scenarios.live.errors import ArmPosesError
    from scenarios.live.recorded import ReplaySpec, episode_on_recording, fit_calibration
    from scenarios.runners.trial_loop import HandSettings
    from sim.hand.objects import make_object
    from sim.recording import load_recording

    check_choice("--controller", args.controller, controller_names())
    check_choice("--object", args.object, object_names())
    poses = None
    if args.arm_poses is not None:
        try:
            poses = ArmPoses.from_text(args.arm_poses)
        except ArmPosesError as exc:
            raise UsageError(f"--arm-poses: {exc}") from None
    hand = HandSettings(args.drive, args.paradigm, args.auto_grip, args.decoder)
    cal_recording = load_recording(args.calibration)
    decoder = checked_decoder(cal_recording, hand)  # before the recording is replayed
    recording = load_recording(args.recording)
    cal = fit_calibration(cal_recording, args.estimator, mode=args.mode,
                          channels=parse_channels(args.channels), seed=args.seed,
                          decoder=decoder)
    overrides = {k: v for k, v in (("mass_kg", args.mass_kg), ("friction", args.friction))
                 if v is not None}
    obj = make_object(args.object, **overrides)
    spec = ReplaySpec(controller=args.controller,
                      episode_s=6.0 if args.episode_s is None else args.episode_s,
                      hold_s=args.hold_s, seed=args.seed,
                      hand=hand)
    result = episode_on_recording(recording, cal, obj, spec, poses=poses,
                                  record_frames=args.video is not None)
    m = result.metrics
    arm = ("the recorded forearm's pitch" if recording.pitch_rad is not None
           else "the scripted lift (no pitch recorded)")
    print(f"episode on {args.recording}: {args.estimator} ({args.mode}, calibration R2 "
          f"{cal.calibration.r2:.3f}) -> {args.controller} on {obj.name} ({obj.mass_kg:g} kg, "
          f"mu {obj.friction:g}), paradigm {args.paradigm}"
          f"{'' if decoder is None else f' ({decoder} decoder)'}, {args.drive} drive; "
          f"the wrist follows {arm}")
    for key in RECORDED_KEYS + (("decoder_windows", "unrequested_opens") if decoder else ()):
        value = m.get(key)
        text = f"{value:.4g}" if isinstance(value, float) else str(value)
        print(f"  {key:<30} {text}")
    if args.json is not None:
        out = {"recording": str(args.recording), "calibration": cal.summary(),
               "controller": args.controller, **spec.hand.fields(),
               "arm": "pitch" if recording.pitch_rad is not None else "scripted",
               "object": {"name": obj.name, "mass_kg": obj.mass_kg, "friction": obj.friction},
               "metrics": m,
               "traces": {k: np.asarray(v).tolist() for k, v in result.traces.items()
                          if k in ("t_s", "reference_n", "grip_force_n", "command",
                                   "object_height_m", "wrist_height_m")}}
        _write_json(args.json, out)
    return _write_video(args, result)


def _compiled_digests(result: Any) -> dict[str, str | None]:
    """The digests of the compiled controller (and so of the export) an episode ran."""
    return {"controller_digest": getattr(result.design.controller, "digest", None)}


def _write_json(path: Path, out: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=1, default=float))
    print(f"wrote {path}")


def _write_video(args: argparse.Namespace, result: Any) -> int:
    if args.video is not None:
        write_video(result.traces["frames"], args.video, fps=25)
        print(f"wrote {args.video}")
    return 0


def _visited(row: dict[str, Any]) -> set[float]:
    """Grid forces the episode visited (stored in the row by the runner)."""
    text = row.get("visited_forces_n") or ""
    return {float(f) for f in text.split(",") if f}
