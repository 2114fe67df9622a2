"""``griploop export``: write a results store as Parquet and/or CSV."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.export import export_store
from scenarios.store import EXPORT_FORMATS, STATUSES, ResultStore


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``export`` subcommand."""
    parser = subparsers.add_parser(
        "export",
        help="write a results store as Parquet and CSV tables",
        description="Flatten the results store into one table (one row per scenario: hash, "
        "status, error, timings, config.<field> and result.<name> columns) and write it as "
        "Parquet and/or CSV. Traces and tracebacks stay in the store.",
    )
    parser.add_argument("db", metavar="RESULTS", help="results store written by griploop sweep")
    parser.add_argument(
        "--out",
        metavar="STEM",
        help="output path without extension (default: RESULTS without its extension)",
    )
    parser.add_argument(
        "--format",
        choices=(*EXPORT_FORMATS, "both"),
        default="both",
        help="file format(s) to write (default: both)",
    )
    parser.add_argument("--sweep", metavar="NAME", help="only the scenarios of this sweep")
    parser.add_argument("--status", choices=STATUSES, help="only rows with this status")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the command; returns the exit status."""
    db = Path(args.db)
    if not db.is_file():
        raise FileNotFoundError(
            f"{db}: no such results store (expected a file written by griploop sweep)"
        )
    formats = EXPORT_FORMATS if args.format == "both" else (args.format,)
    stem = Path(args.out) if args.out else db.with_suffix("")
    with ResultStore(db, read_only=True) as store:
        written = export_store(store, stem, formats, sweep=args.sweep, status=args.status)
    for path in written:
        print(path)
    return 0
