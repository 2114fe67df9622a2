"""``griploop margins``: design a controller for an object and report its loop margins.

Example::

    griploop margins --controller pid --object can --mass-kg 0.4 --friction 0.5 \\
        --json margins.json --plots figs/
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from controllers.analysis import LoopMargins
from controllers.figures import save_loop_figures
from controllers.registry import CONTROLLER_NAMES, design_controller
from scenarios.plant_models import PLANT_METHODS, design_plant, object_force_bounds

# Specifications used when none are given; chosen for the simulated hand, whose
# command-to-force response is nearly static over the control band (~88 N per
# unit command plus the sample-and-hold and one period of computation delay).
DEFAULT_SPECS: dict[str, dict[str, Any]] = {
    "pid": {"phase_margin_deg": 60.0, "crossover_rad_s": 30.0, "structure": "pi"},
    "lead_lag": {"phase_margin_deg": 60.0, "crossover_rad_s": 30.0, "lag_ratio": 2.0},
    "mpc": {"horizon": 20},
}


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``margins`` subcommand."""
    p = subparsers.add_parser(
        "margins",
        help="design a controller for an object and report gain/phase/delay margins",
        description="Design a force controller from specifications on the object's design "
        "plant and print its loop margins (all crossovers, delay margin, Ms, poles).",
    )
    p.add_argument("--controller", required=True, metavar="NAME",
                   help=f"one of {', '.join(CONTROLLER_NAMES)}")
    p.add_argument("--object", required=True, metavar="NAME", help="object name (sim.objects)")
    p.add_argument("--mass-kg", type=float, default=None, help="override the object's mass, kg")
    p.add_argument("--friction", type=float, default=None, help="override the friction coeff.")
    p.add_argument("--json", required=True, type=Path, metavar="FILE", help="write results here")
    p.add_argument("--plots", type=Path, default=None, metavar="DIR",
                   help="write Bode, Nyquist and pole-zero PNGs here")
    p.add_argument("--plant", default="linearized", metavar="METHOD",
                   help=f"design plant: one of {', '.join(PLANT_METHODS)} (default linearized)")
    p.add_argument("--phase-margin-deg", type=float, default=None,
                   help="target phase margin (pid, lead_lag)")
    p.add_argument("--crossover-rad-s", type=float, default=None,
                   help="target crossover frequency (pid, lead_lag)")
    p.add_argument("--grip-force-n", type=float, default=None,
                   help="operating grip force of the design plant, N")
    p.add_argument("--dt-s", type=float, default=0.01, help="control period, s (default 0.01)")
    p.set_defaults(func=run)


def _spec(args: argparse.Namespace, bounds: Any) -> dict[str, Any]:
    spec = dict(DEFAULT_SPECS.get(args.controller, {}))
    loop_shaping = {"phase_margin_deg": args.phase_margin_deg,
                    "crossover_rad_s": args.crossover_rad_s}
    given = {k: v for k, v in loop_shaping.items() if v is not None}
    if args.controller == "mpc":
        if given:
            raise ValueError(
                f"margins: mpc is specified by horizon and weights, found loop-shaping options "
                f"{sorted(given)}"
            )
        spec["force_bounds"] = bounds
    else:
        spec.update(given)
    return spec


def format_table(controller: str, margins: LoopMargins) -> str:
    """The margin table printed by the command."""
    m = margins
    dm_samples = "" if m.delay_margin_samples is None else f" ({m.delay_margin_samples} samples)"
    rows = [
        ("gain margin", f"{m.gain_margin_db:.2f} dB"),
        ("phase margin", f"{m.phase_margin_deg:.2f} deg"),
        ("delay margin", f"{m.delay_margin_s * 1e3:.1f} ms{dm_samples}"),
        ("gain crossovers", ", ".join(f"{w:.4g}" for w in m.crossover_rad_s) + " rad/s"),
        ("phase margins", ", ".join(f"{p:.2f}" for p in m.phase_margins_deg) + " deg"),
        ("phase crossovers", ", ".join(f"{w:.4g}" for w in m.phase_crossover_rad_s) + " rad/s"),
        ("peak sensitivity Ms", f"{m.ms:.3f} at {m.ms_frequency_rad_s:.4g} rad/s"),
        ("bandwidth", f"{m.bandwidth_rad_s:.4g} rad/s"),
        ("max |closed-loop pole|", f"{np.max(np.abs(m.closed_loop_poles)):.4f}"),
        ("stable", str(m.stable)),
    ]
    width = max(len(r[0]) for r in rows)
    lines = [f"margins of {controller}"] + [f"  {k:<{width}}  {v}" for k, v in rows]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop margins``; returns the exit status."""
    if args.controller not in CONTROLLER_NAMES:  # checked before the (slower) plant build
        design_controller(args.controller, None)
    plant = design_plant(args.object, mass_kg=args.mass_kg, friction=args.friction,
                         method=args.plant, grip_force_n=args.grip_force_n,
                         control_dt_s=args.dt_s)
    bounds = object_force_bounds(plant.object)
    controller = design_controller(args.controller, plant.model, **_spec(args, bounds))
    report = controller.report_
    margins = report.margins
    print(format_table(args.controller, margins))
    result = {
        "controller": args.controller,
        "object": {"name": plant.object.name, "mass_kg": plant.object.mass_kg,
                   "friction": plant.object.friction,
                   "break_force_n": plant.object.break_force_n},
        "force_bounds_n": {"min": bounds.min_n,
                           "max": None if not np.isfinite(bounds.max_n) else bounds.max_n},
        "plant": {"method": plant.method, "u0": plant.u0, "y0_n": plant.y0_n,
                  "order": int(plant.model.nstates), "fit": plant.fit},
        "design": {"spec": {k: v for k, v in report.spec.items()},
                   "parameters": report.parameters, "notes": report.notes},
        "margins": margins.to_dict(),
    }
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(result, indent=2, default=float))
    if args.plots is not None:
        stem = f"{args.controller}_{plant.object.name}"
        for path in save_loop_figures(margins, args.plots, stem):
            print(f"wrote {path}")
    print(f"wrote {args.json}")
    return 0
