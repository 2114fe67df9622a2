"""``griploop margins``: design a controller for an object and report its loop margins over force.

Example::

    griploop margins --controller pid --object can --mass-kg 0.4 --friction 0.5 \\
        --at-force 3,5,10,20 --json margins.json --plots figs/

A margin is a property of a loop at an operating point: every row is the
controller that runs at that grip force, on the plant linearized at that force.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from controllers.design import (
    ControllerDesign,
    OperatingAnalysis,
    worst_case,
)
from controllers.design_cache import grasp_design
from controllers.design_plant import object_for
from controllers.figures import margins_over_force_figure, save_loop_figures
from controllers.registry import check_options, default_spec
from scenarios.cli.choices import check_choice, controller_names, object_names, one_of
from scenarios.cli.errors import UsageError


def parse_forces(text: str) -> list[float]:
    """``"3,5,10"`` -> ``[3.0, 5.0, 10.0]``; a one-line error otherwise."""
    try:
        forces = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise UsageError(
            f"--at-force: expected comma-separated forces in N, found {text!r}") from None
    if not forces or not all(np.isfinite(forces)):
        raise UsageError(f"--at-force: expected comma-separated forces in N, found {text!r}")
    return forces


def add_design_options(p: argparse.ArgumentParser) -> None:
    """Options shared by ``margins`` and ``measure-loop``: controller, object, specification."""
    p.add_argument("--controller", required=True, metavar="NAME",
                   help=one_of(controller_names()))
    p.add_argument("--object", required=True, metavar="NAME", help=one_of(object_names()))
    p.add_argument("--mass-kg", type=float, default=None, help="override the object's mass, kg")
    p.add_argument("--friction", type=float, default=None, help="override the friction coeff.")
    p.add_argument("--phase-margin-deg", type=float, default=None,
                   help="target phase margin (pid, lead_lag; default 60)")
    p.add_argument("--crossover-rad-s", type=float, default=None,
                   help="target crossover frequency (pid, lead_lag; default 30)")
    p.add_argument("--fixed-at-n", type=float, default=None, metavar="F",
                   help="one fixed-gain design at grip force F (N) instead of the gain-scheduled "
                   "designs")
    p.add_argument("--dt-s", type=float, default=0.01, help="control period, s (default 0.01)")


def design_from_args(args: argparse.Namespace) -> ControllerDesign:
    """The design the shared options describe (library defaults where none are given)."""
    check_choice("--controller", args.controller, controller_names())
    spec = default_spec(args.controller)
    shaping = {"phase_margin_deg": args.phase_margin_deg, "crossover_rad_s": args.crossover_rad_s}
    given = {k: v for k, v in shaping.items() if v is not None}
    check_options(args.controller, given)  # e.g. mpc takes no loop-shaping options
    spec.update(given)
    obj = object_for(args.object, mass_kg=args.mass_kg, friction=args.friction)
    if args.fixed_at_n is not None:
        spec.update(scheduled=False, operating_force_n=args.fixed_at_n)
    return grasp_design(obj, args.controller, args.dt_s, spec)  # as an episode designs it


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``margins`` subcommand."""
    p = subparsers.add_parser(
        "margins",
        help="design a controller for an object and report its margins at each grip force",
        description="Design a force controller from specifications over the object's force "
        "range (gain-scheduled, or fixed with --fixed-at-n) and print its loop margins at each "
        "grip force, on the plant linearized at that force, ending with the worst case.",
    )
    add_design_options(p)
    p.add_argument("--at-force", type=parse_forces, default=None, metavar="F1,F2,...",
                   help="analyse at these grip forces, N (default: the design grid)")
    p.add_argument("--json", type=Path, default=None, metavar="FILE", help="also write JSON here")
    p.add_argument("--plots", type=Path, default=None, metavar="DIR",
                   help="write margins-over-force, Bode, Nyquist and pole-zero PNGs here")
    p.set_defaults(func=run)


def _cell(x: float | None, fmt: str) -> str:
    return "-" if x is None or not np.isfinite(x) else format(x, fmt)


def format_table(controller: str, analyses: list[OperatingAnalysis],
                 worst: dict[str, Any] | None = None) -> str:
    """The per-force margin table printed by the command, with the worst case last."""
    head = (f"{'force N':>8} {'GM dB':>7} {'PM deg':>7} {'DM ms':>7} {'wc rad/s':>9} "
            f"{'Ms':>5} {'stable':>6}  plant")
    lines = [f"margins of {controller} (each row: the loop that runs at that force)", head]
    for a in analyses:
        if not a.ok:
            lines.append(f"{a.force_n:8.3g}  failed: {a.reason}")
            continue
        m = a.margins
        wc = m.crossover_rad_s[0] if m.crossover_rad_s else None
        dm_ms = m.delay_margin_s * 1e3 if np.isfinite(m.delay_margin_s) else None
        lines.append(f"{a.force_n:8.3g} {_cell(m.gain_margin_db, '7.2f')} "
                     f"{_cell(m.phase_margin_deg, '7.1f')} "
                     f"{_cell(dm_ms, '7.1f')} "
                     f"{_cell(wc, '9.3g')} {_cell(m.ms, '5.2f')} {str(m.stable):>6}  {a.how}")
    if worst and worst.get("n_points"):
        dm = worst["delay_margin_s"]
        lines.append(
            f"{'worst':>8} {_cell(worst['gain_margin_db'], '7.2f')} "
            f"{_cell(worst['phase_margin_deg'], '7.1f')} "
            f"{_cell(None if dm is None else dm * 1e3, '7.1f')} {'':>9} "
            f"{_cell(worst['ms'], '5.2f')} {str(worst['all_stable']):>6}  "
            f"(PM at {worst['phase_margin_at_n']:g} N, GM at {worst['gain_margin_at_n']:g} N)"
        )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Run ``griploop margins``; returns the exit status."""
    design = design_from_args(args)
    if args.at_force is None:
        forces = [p.force_n for p in design.family.points]
    else:
        forces = args.at_force
        for f in forces:
            design.check_force(f)
    analyses = design.analyse_many(forces)
    worst = worst_case(analyses)
    fam = design.family
    where = "" if fam.source.startswith("built") else f", read from the {fam.source} cache"
    print(f"plant family of {design.object.name}: {len(fam.points)} grid forces "
          f"{fam.range_n[0]:g}..{fam.range_n[1]:g} N built in {fam.build_s:.2f} s{where}")
    print(format_table(args.controller, analyses, worst))
    obj = design.object
    result = {
        "controller": args.controller,
        "object": {"name": obj.name, "mass_kg": obj.mass_kg, "friction": obj.friction,
                   "break_force_n": obj.break_force_n},
        "design": {"spec": design.spec, "notes": design.notes,
                   "plant_family": design.family.summary(),
                   "plant_family_build_s": design.family.build_s},
        "operating_points": [a.to_dict() for a in analyses],
        "worst_case": worst,
    }
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1, default=float))
        print(f"wrote {args.json}")
    if args.plots is not None:
        args.plots.mkdir(parents=True, exist_ok=True)
        stem = f"{args.controller}_{obj.name}"
        fig = margins_over_force_figure({args.controller: analyses}, title=obj.name)
        path = args.plots / f"{stem}_margins_over_force.png"
        fig.savefig(path, dpi=110)
        print(f"wrote {path}")
        shown = [a for a in analyses if a.ok]
        if shown:
            worst_pm = min(shown, key=lambda a: a.margins.phase_margin_deg)
            for path in save_loop_figures(worst_pm.margins, args.plots,
                                          f"{stem}_at_{worst_pm.force_n:g}N"):
                print(f"wrote {path}")
    return 0
