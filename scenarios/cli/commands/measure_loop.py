"""``griploop measure-loop``: measure the loop gain on the nonlinear hand by sine injection.

Example::

    griploop measure-loop --controller pid --object can --mass-kg 0.2 --friction 1.0 \\
        --at-force 3,5,10,20 --json measured.json --plots figs/

At each force the hand holds the object in the air under the designed
controller; small sines are injected at the plant input and the loop gain
``L = -U_c / U`` is read from the signals (:mod:`controllers.measure`), beside
the prediction of the analysis at the force actually held.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from controllers.figures import measured_bode_figure
from controllers.measure import measure_loop
from scenarios.cli.choices import add_drive_option, check_drive
from scenarios.cli.commands.margins import add_design_options, design_from_args, parse_forces


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``measure-loop`` subcommand."""
    p = subparsers.add_parser(
        "measure-loop",
        help="measure L(jw) and |S(jw)| on the simulated hand by sine injection",
        description="Hold the object in the air at each force under the designed controller, "
        "inject small sines at the plant input and report the measured loop gain, crossover "
        "and phase margin beside the predicted ones.",
    )
    add_design_options(p)
    p.add_argument("--at-force", type=parse_forces, required=True, metavar="F1,F2,...",
                   help="hold forces, N")
    p.add_argument("--frequencies", type=parse_forces, default=None, metavar="W1,W2,...",
                   help="injection frequencies, rad/s (default: around the predicted crossover)")
    add_drive_option(p)
    p.add_argument("--json", type=Path, default=None, metavar="FILE", help="also write JSON here")
    p.add_argument("--plots", type=Path, default=None, metavar="DIR",
                   help="write predicted Bode plots with the measured points overlaid")
    p.set_defaults(func=run)


def _f(x: float | None, fmt: str) -> str:
    return "-" if x is None else format(x, fmt)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop measure-loop``; returns the exit status."""
    check_drive(args.drive)
    design = design_from_args(args)
    for f in args.at_force:
        design.check_force(f)
    freqs = None if args.frequencies is None else np.asarray(args.frequencies)
    print(f"measured on the MuJoCo hand ({args.drive} drive): {args.controller} holding "
          f"{design.object.name}")
    print(f"{'force N':>8} {'held N':>7} {'wc meas':>8} {'wc pred':>8} {'PM meas':>8} "
          f"{'PM pred':>8} {'|L(wc_pred)| dB':>16}")
    results = []
    for f in args.at_force:
        m = measure_loop(design, f, frequencies_rad_s=freqs, drive=args.drive)
        results.append(m)
        if m.reason:
            print(f"{f:8.3g}  failed: {m.reason}")
            continue
        print(f"{f:8.3g} {m.held_force_n:7.2f} {_f(m.crossover_rad_s, '8.3g')} "
              f"{_f(m.predicted_crossover_rad_s, '8.3g')} {_f(m.phase_margin_deg, '8.1f')} "
              f"{_f(m.predicted_phase_margin_deg, '8.1f')} "
              f"{_f(m.gain_at_predicted_crossover_db, '16.2f')}")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({
            "controller": args.controller, "drive": args.drive,
            "object": {"name": design.object.name, "mass_kg": design.object.mass_kg,
                       "friction": design.object.friction},
            "design": {"spec": design.spec},
            "measurements": [m.to_dict() for m in results]}, indent=1, default=float))
        print(f"wrote {args.json}")
    if args.plots is not None:
        args.plots.mkdir(parents=True, exist_ok=True)
        for m in results:
            if m.reason or not m.points:
                continue
            held = float(np.clip(round(m.held_force_n, 1), *design.family.range_n))
            analysis = design.analyse(held)
            fig = measured_bode_figure(
                analysis.margins, np.array([p.frequency_rad_s for p in m.points]),
                np.array([p.loop for p in m.points]),
                title=f"{args.controller} holding {design.object.name} at {held:g} N")
            stem = f"{args.controller}_{design.object.name}_{m.force_n:g}N"
            path = args.plots / f"{stem}_measured.png"
            fig.savefig(path, dpi=110)
            print(f"wrote {path}")
    return 0
