"""``griploop subjects``: record the paper's calibration session for a virtual population."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from scenarios.cli.choices import generator_names
from scenarios.cli.errors import UsageError
from sim.user.subjects import make_population


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``subjects`` subcommand."""
    parser = subparsers.add_parser(
        "subjects",
        help="simulate the paper's squeeze session for a virtual population",
        description="Draw a seeded population of virtual subjects and record one paper-protocol "
        "calibration session each (8-channel int8 sEMG at the MYO rate plus FSR force). Writes "
        "DIR/subjectNN.npz and DIR/subjectNN.csv (with its JSON sidecar subjectNN.csv.json; "
        "docs/FORMAT.md) and prints one summary line per subject.",
    )
    parser.add_argument("--n", type=int, default=10, help="number of subjects (default: 10)")
    parser.add_argument("--seed", type=int, default=0, help="population seed (default: 0)")
    parser.add_argument(
        "--generator",
        choices=generator_names(),
        default="noise",
        help="sEMG model: amplitude-modulated noise or motor-unit pools (default: noise)",
    )
    parser.add_argument(
        "--fs-hz", type=float, default=200.0, help="sEMG sampling rate in Hz (default: 200)"
    )
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory")
    parser.add_argument("--grasp", metavar="OBJECT", default=None,
                        help="also record each subject grasping, lifting and holding this object "
                        "(DIR/subjectNN_grasp.npz, aiming at the force an episode's user aims at "
                        "through this session's calibration, the forearm's pitch of their lift "
                        "as pitch_rad; the calibration files then carry the subject's arm poses): "
                        "a recording to stream to griploop live")
    parser.add_argument("--grasp-s", type=float, default=9.0,
                        help="length of the grasp recording, s (default 9)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    if args.n < 1:
        raise UsageError(f"--n must be at least 1, found {args.n}")
    if args.seed < 0:
        raise UsageError(f"--seed must be non-negative, found {args.seed}")
    obj = None
    if args.grasp is not None:
        from scenarios.cli.choices import check_choice, object_names
        from sim.hand.objects import make_object

        obj = make_object(check_choice("--grasp", args.grasp, object_names()))
        if not args.grasp_s >= 3.0:
            raise UsageError(f"--grasp-s must be at least 3 s, found {args.grasp_s}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for subject in make_population(args.n, args.seed):
        rec = subject.paper_session(generator=args.generator, fs_hz=args.fs_hz)
        if obj is not None:  # the arm poses griploop calibrate would have asked for
            from scenarios.live.arm import virtual_arm_poses

            rec.metadata["arm_poses"] = virtual_arm_poses().to_metadata()
        stem = out / f"subject{subject.subject_id:02d}"
        rec.save_npz(stem.with_suffix(".npz"))
        rec.save_csv(stem.with_suffix(".csv"))
        rest = rec.intent < 1e-3
        rest_std = float(np.std(rec.emg[rest].astype(float))) if rest.any() else float("nan")
        saturated = 100.0 * rec.metadata["n_saturated"] / rec.emg.size
        print(
            f"subject{subject.subject_id:02d}  mvc {subject.mvc_n:5.1f} N  "
            f"{rec.duration_s:5.1f} s  peak FSR {rec.force_n.max():5.1f} N  "
            f"rest std {rest_std:4.2f} LSB  saturated {saturated:5.3f} %  "
            f"-> {stem}.npz, {stem}.csv"
        )
        if obj is not None:
            from scenarios.live.recorded import GraspScript, grasp_session

            grasp = grasp_session(subject, obj, mvc_cal_n=float(rec.force_n.max()),
                                  duration_s=args.grasp_s - 1.0,
                                  rng=np.random.default_rng((args.seed, subject.subject_id)),
                                  script=GraspScript(generator=args.generator,
                                                     fs_hz=args.fs_hz, tail_s=1.0))
            path = grasp.save_npz(out / f"subject{subject.subject_id:02d}_grasp.npz")
            print(f"subject{subject.subject_id:02d}  grasp of {obj.name}: target "
                  f"{grasp.metadata['target_grip_n']:.2f} N on the hand, "
                  f"{grasp.duration_s:.1f} s -> {path}")
    return 0
