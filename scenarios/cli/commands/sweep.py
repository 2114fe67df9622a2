"""``griploop sweep``: run a YAML sweep into the results store, resumably."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from scenarios.execution.sweep import (
    DEFAULT_TASK,
    SweepError,
    SweepExecution,
    count_pending,
    iter_plan,
    run_sweep,
)
from scenarios.schema import (
    DEFAULT_MAX_SCENARIOS,
    SweepConfig,
    check_size,
    design_size,
    iter_expanded,
    load_sweep,
)
from scenarios.store import ResultStore

DEFAULT_DB = "griploop-results.sqlite"

_EPILOG = """\
Each scenario is stored once under a content hash of its configuration, the
griploop version and the task; running the same sweep again skips the stored
ones, so an interrupted sweep (even killed with SIGKILL) resumes where it
stopped. A scenario that raises is stored as failed with its traceback and
the sweep goes on; so is a scenario still running after the sweep file's
time_limit_s (default 120 s), recorded with a "timeout" error, and one that
kills its process twice. The number of scenarios is counted from the design
before anything is expanded and refused above --max-scenarios. Two drivers
on one store share the work: each scenario is claimed before it runs.
Ctrl-C or SIGTERM stops the sweep at once: the scenarios then running are
not stored (never as failed) and run on the next call.
Exit status: 0 when the sweep completed (failed rows included), 2 on a user
error (bad file, option, scheduler address, full disk, read-only store),
130 / 143 when stopped by Ctrl-C / SIGTERM.

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
        help="number of worker processes, forked from this one (default 1); each runs its "
        "scenarios one at a time",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing dask scheduler, e.g. tcp://host:8786, instead of local workers",
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
        help="validate the sweep, count its scenarios from the design and print how many are "
        "pending, run nothing",
    )
    parser.add_argument(
        "--max-scenarios",
        type=int,
        default=DEFAULT_MAX_SCENARIOS,
        metavar="N",
        help=f"refuse a sweep of more than N scenarios (default: {DEFAULT_MAX_SCENARIOS}; "
        "0: no cap)",
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
    if args.max_scenarios < 0:
        raise SweepError(f"--max-scenarios must be >= 0 (found {args.max_scenarios})")
    cap = args.max_scenarios or None
    spec = load_sweep(args.file)
    if args.dry_run:
        return _dry_run(args, spec, cap)
    total = check_size(spec, cap, args.file)
    planned = iter_plan(iter_expanded(spec, args.file, max_scenarios=cap), args.task)
    with ResultStore(args.db) as store:
        summary = run_sweep(
            planned,
            store,
            SweepExecution(task=args.task, workers=workers, scheduler=args.scheduler,
                           time_limit_s=spec.time_limit_s, plugins=spec.plugins),
            total=total,
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


def _dry_run(args: argparse.Namespace, spec: SweepConfig, cap: int | None) -> int:
    """Print the design's size (counted, not expanded) and, for a runnable size, what is pending."""
    total = design_size(spec)
    if cap is not None and total > cap:
        print(f"{spec.name}: {total} scenarios, above --max-scenarios {cap}: "
              "griploop sweep would refuse it")
        return 0
    if total > DEFAULT_MAX_SCENARIOS:
        print(f"{spec.name}: {total} scenarios (too many to look each up in the store)")
        return 0
    if not Path(args.db).is_file():
        print(f"{spec.name}: {total} scenarios, 0 stored, {total} to run")
        return 0
    planned = iter_plan(iter_expanded(spec, args.file, max_scenarios=cap), args.task)
    with ResultStore(args.db, read_only=True) as store:
        total, todo = count_pending(planned, store, retry_failed=args.retry_failed)
    print(f"{spec.name}: {total} scenarios, {total - todo} stored, {todo} to run")
    return 0
