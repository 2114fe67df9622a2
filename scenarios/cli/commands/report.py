"""``griploop report``: a self-contained HTML report of a results store."""

from __future__ import annotations

import argparse
import os


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``report`` subcommand."""
    parser = subparsers.add_parser(
        "report",
        help="write a self-contained HTML report of a results store",
        description="Write DIR/index.html. It opens with what the sweep found: the factor "
        "that changes the outcome most, in one sentence from the numbers, outcome rates "
        "with 95 % intervals by factor, paired controller differences and the held rate "
        "by the strongest factors. Then the table per combination, the paper's tables next "
        "to ours (one_step and free_run apart), force traces, Bode/Nyquist/pole maps and "
        "margin tables per controller design, outcome maps, a rendered grasp, failed "
        "scenarios and provenance. Figures are embedded SVG; the page needs no JavaScript "
        "and no network. Sections without data are replaced by a one-line note.",
    )
    parser.add_argument("db", metavar="RESULTS", help="results store written by griploop sweep")
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory")
    parser.add_argument("--sweep", metavar="NAME", help="only the scenarios of this sweep")
    parser.add_argument("--reproduction", metavar="FILE.json",
                        help="JSON written by griploop reproduce --json")
    parser.add_argument("--no-render", action="store_true",
                        help="skip the MuJoCo frame of the grasp")
    parser.add_argument("--recheck-margins", action="store_true",
                        help="re-analyse every loop design and compare with the stored margins "
                        "(imports python-control; about 0.1 s per design)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    os.environ.setdefault("MUJOCO_GL", "egl")
    from scenarios.report import build_report

    result = build_report(args.db, args.out, sweep=args.sweep, reproduction=args.reproduction,
                          render_frame=not args.no_render, recheck_margins=args.recheck_margins)
    omitted = [s.title for s in result.sections if s.omitted]
    size_kb = result.path.stat().st_size / 1024
    print(f"wrote {result.path} ({len(result.sections) - len(omitted)} of "
          f"{len(result.sections)} sections, {result.n_images} figures, {size_kb:.0f} KB) "
          f"in {result.elapsed_s:.1f} s")
    for title in omitted:
        print(f"  no data: {title}")
    return 0
