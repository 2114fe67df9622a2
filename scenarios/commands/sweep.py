"""``griploop sweep``: run a YAML sweep into the results store, resumably."""

from __future__ import annotations

import argparse
import sys

from scenarios.schema import expand_sweep, load_sweep
from scenarios.store import ResultStore
from scenarios.sweep import DEFAULT_TASK, SweepError, pending, plan, run_sweep

DEFAULT_DB = "griploop-results.sqlite"

_EPILOG = """\
Each scenario is stored once under a content hash of its configuration, the
griploop version and the task; running the same sweep again skips the stored
ones, so an interrupted sweep (even killed with SIGKILL) resumes where it
stopped. A scenario that raises is stored as failed with its traceback and
the sweep goes on. Exit status: 0 when the sweep completed (failed rows
included), 2 on a user error (bad file, option or scheduler address).

examples:
  griploop sweep scenarios/library/grasp_mass_friction.yaml --workers 2
  griploop sweep my_sweep.yaml --scheduler tcp://10.0.0.5:8786 --db runs.sqlite
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``sweep`` subcommand."""
    parser = subparsers.add_parser(
        "sweep",
        help="run a YAML sweep of scenarios into the results store (resumable)",
        description="Expand a sweep file (base scenario x grid or random design), run\n"
        "every scenario not yet in the store, and record each result as it arrives.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", metavar="FILE.yaml", help="sweep file (see scenarios/library/)")
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="1 runs in this process (default); N > 1 starts a local dask cluster of N "
        "single-threaded worker processes",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing dask scheduler, e.g. tcp://host:8786, instead of a local cluster",
    )
    parser.add_argument(
        "--db", default=DEFAULT_DB, metavar="PATH", help=f"results store (default: {DEFAULT_DB})"
    )
    parser.add_argument(
        "--task",
        default=DEFAULT_TASK,
        metavar="MODULE:FUNCTION",
        help="callable run on each scenario, returning a flat dict of scalars "
        f"(default: {DEFAULT_TASK}, which dispatches on the scenario kind)",
    )
    parser.add_argument(
        "--retry-failed", action="store_true", help="run scenarios stored as failed again"
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="validate and expand the sweep, print how many scenarios are pending, run nothing",
    )
    parser.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    if args.scheduler is not None and args.workers is not None:
        raise SweepError("give --workers or --scheduler, not both")
    workers = 1 if args.workers is None else args.workers
    if workers < 1:
        raise SweepError(f"--workers must be >= 1 (found {workers})")
    spec = load_sweep(args.file)
    planned = plan(expand_sweep(spec, args.file), args.task)
    with ResultStore(args.db) as store:
        if args.dry_run:
            todo = pending(planned, store, retry_failed=args.retry_failed)
            print(
                f"{spec.name}: {len(planned)} scenarios, {len(planned) - len(todo)} stored, "
                f"{len(todo)} to run"
            )
            return 0
        summary = run_sweep(
            planned,
            store,
            task=args.task,
            workers=workers,
            scheduler=args.scheduler,
            sweep_name=spec.name,
            retry_failed=args.retry_failed,
            progress=not args.no_progress,
        )
    print(
        f"{spec.name}: {summary.total} scenarios, {summary.skipped} already stored, "
        f"{summary.ok} ok, {summary.failed} failed in {summary.elapsed_s:.1f} s "
        f"({summary.rate_per_min:.1f}/min) -> {args.db}",
        file=sys.stdout,
    )
    return 0
