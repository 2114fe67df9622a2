"""``griploop export-c``: the fitted estimator and the designed controller as C for a prosthesis."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from scenarios.cli.choices import (
    add_hand_options,
    check_hand_options,
    controller_names,
    object_names,
    one_of,
)
from scenarios.cli.errors import UsageError
from scenarios.cli.recording_options import add_recording_options, load_with_options

TARGETS = ("cortex-m4",)


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``export-c`` subcommand."""
    p = subparsers.add_parser(
        "export-c",
        help="write the fitted estimator and the designed controller as C99 for a "
        "microcontroller",
        description="Fit the estimator on a calibration recording (as evaluate does), design "
        "the controller for an object (as an episode does), and write C99 files: the feature "
        "window, the estimator, the controller, a header with units, rates, state sizes and "
        "the callbacks you write. With --paradigm velocity (or --decoder) the calibration must "
        "hold open contractions (griploop calibrate --open): the open/close decoder, its MAV "
        "window over every channel and the paradigm's shaping are exported too. --check "
        "compiles them with the host C compiler and replays "
        "a recording through C and Python; --target cortex-m4 also runs that replay on an "
        "emulated Cortex-M4F (arm-none-eabi-gcc, qemu-system-arm). docs/DEPLOY.md walks "
        "through it.",
    )
    p.add_argument("--calibration", required=True, type=Path, metavar="CAL",
                   help="calibration recording (.npz or .csv, with the measured force)")
    add_recording_options(p)
    p.add_argument("--estimator", required=True, metavar="NAME",
                   help="the estimator to export (ss_kf, latent_kf, mlp, adaptive_mlp, "
                        "transfer_mlp, ...)")
    p.add_argument("--mode", default="free_run", help="free_run (default) or one_step")
    p.add_argument("--channels", default="6,7,8",
                   help="'all' or comma-separated channels (default: 6,7,8)")
    p.add_argument("--controller", default=None, metavar="NAME", help=one_of(controller_names()))
    p.add_argument("--object", default=None, metavar="NAME",
                   help="the object the controller is designed for: " + one_of(object_names()))
    p.add_argument("--out", required=True, type=Path, metavar="DIR", help="folder for the files")
    p.add_argument("--check", default=None, type=Path, metavar="RECORDING",
                   help="compile on the host and replay this recording through C and Python")
    p.add_argument("--target", default=None, metavar="TARGET",
                   help="with --check: also run the replay on an emulated " + one_of(TARGETS))
    add_hand_options(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the fit and the hand (default 0)")
    p.add_argument("--json", default=None, type=Path, metavar="FILE", help="also write JSON here")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop export-c``; returns the exit status."""
    from estimation.reproduce import parse_channels
    from scenarios.cli.choices import check_choice
    from scenarios.deploy.session import ExportSpec, export_session
    from scenarios.runners.trial_loop import HandSettings

    if (args.controller is None) != (args.object is None):
        raise UsageError("--controller and --object go together; found only "
                         + ("--controller" if args.object is None else "--object"))
    if args.controller is not None:
        check_choice("--controller", args.controller, controller_names())
        check_choice("--object", args.object, object_names())
    check_hand_options([args.paradigm], args.drive, args.decoder)
    if args.target is not None:
        check_choice("--target", args.target, TARGETS)
        if args.check is None:
            raise UsageError("--target runs the replay of --check RECORDING; found no --check")
    try:
        channels = parse_channels(args.channels)
    except ValueError as exc:
        raise UsageError(f"--channels: {exc}") from None
    calibration = load_with_options(args.calibration, args)
    check = None if args.check is None else load_with_options(args.check, args)
    spec = ExportSpec(args.estimator, channels, mode=args.mode, controller=args.controller,
                      object_name=args.object, seed=args.seed,
                      hand=HandSettings(args.drive, args.paradigm, args.auto_grip,
                                        args.decoder))
    export, report = export_session(calibration, spec, args.out, check_recording=check,
                                    target=args.target)
    print(f"export-c: {len(export.files)} files in {args.out}")
    for name, part in report["models"].items():
        if part is not None:
            print(f"  {name:<11} digest {part['digest']}")
    if "check" in report:
        c = report["check"]
        err = c["max_abs_error"]
        command = "n/a" if err["command"] is None else f"{err['command']:.3g}"
        print(f"check: {c['samples']} samples, {c['windows']} windows, {c['control_steps']} "
              f"control steps; max |C - Python|: features {err['features']:.3g} "
              f"({c['features_max_ulps']:.2g} float32 ulp), estimate {err['estimate_n']:.3g} N, "
              f"reference ({args.paradigm}) {err['reference_n']:.3g} N, command {command}")
        if "decoder" in c:
            d = c["decoder"]
            print(f"decoder: {d['windows']} windows ({d['open_windows']} open, "
                  f"{d['close_windows']} close); max |C - Python|: levels "
                  f"{d['max_abs_error']:.3g}, labels differing {d['label_mismatches']}, "
                  f"command bounds {d['command_range_max_abs_error']:.3g}")
    if "target" in report:
        t = report["target"]
        ipu = t["instructions_per_update"]
        print(f"target {args.target}: flash {t['flash_bytes']} B, RAM {t['ram_bytes']} B, "
              f"instructions per update: features {ipu['features']}, estimator "
              f"{ipu['estimator']}, controller {ipu['controller']}"
              + (f", decoder {ipu['decoder']} (features + estimator + decoder "
                 f"{ipu['features_estimator_decoder']})" if "decoder" in ipu else "")
              + f"; matches host: {t['matches_host']}")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0
