"""Command-line options that tell the recording loader another tool's CSV layout.

Shared by the commands that read a recording (``evaluate``, ``plot-recording``):
:func:`add_recording_options` declares them, :func:`recording_kwargs` turns the
parsed arguments into keyword arguments of :func:`sim.recording.load_recording`.
A ``--columns`` file gives defaults; options on the command line win.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from sim.recording import DUPLICATES, EMG_UNITS, TIME_UNITS, ColumnMap, read_column_file


def add_recording_options(parser: argparse.ArgumentParser) -> None:
    """Declare the layout options on ``parser`` (in their own help group)."""
    group = parser.add_argument_group(
        "recording layout (CSV from other tools; see docs/FORMAT.md)"
    )
    group.add_argument("--columns", metavar="FILE",
                       help="column map (.yaml or .json) with any of time_column, emg_columns, "
                       "force_column, time_unit, fs_hz, emg_unit, resample_hz, duplicates; "
                       "options given here win")
    group.add_argument("--time-column", metavar="NAME",
                       help="time column (default: t); 'none' if the file has none "
                       "(then give --fs-hz)")
    group.add_argument("--emg-columns", metavar="SPEC",
                       help="sEMG columns in channel order: names 'a,b,c', a glob 'emg_*' "
                       "(file order) or a range 'emg_0..emg_7' (default: emg1..emgN)")
    group.add_argument("--force-column", metavar="NAME",
                       help="measured force column in newtons (default: force); 'none' to "
                       "load without force")
    group.add_argument("--time-unit", choices=TIME_UNITS,
                       help="unit of the time column (default: s)")
    group.add_argument("--fs-hz", type=float, metavar="HZ",
                       help="sampling rate when the file has no time column")
    group.add_argument("--emg-unit", choices=EMG_UNITS,
                       help="unit of the sEMG columns (default: int8 if every value is an "
                       "integer in -128..127, else uV)")
    group.add_argument("--resample", type=float, metavar="HZ",
                       help="interpolate sEMG and force onto a uniform HZ grid, for jittered "
                       "or duplicated time stamps (MYO dumps)")
    group.add_argument("--duplicates", choices=DUPLICATES,
                       help="with --resample: average rows sharing a time stamp (default) or "
                       "spread them evenly up to the next stamp")


def _name(value: str | None) -> str | None:
    return None if value is None or value.strip().lower() == "none" else value.strip()


def recording_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments for ``load_recording`` from the parsed layout options."""
    kwargs: dict[str, Any] = read_column_file(args.columns) if args.columns else {}
    columns: ColumnMap = kwargs.get("columns", ColumnMap())
    changes: dict[str, Any] = {}
    if args.time_column is not None:
        changes["time"] = _name(args.time_column)
    if args.emg_columns is not None:
        changes["emg"] = args.emg_columns
    if args.force_column is not None:
        changes["force"] = _name(args.force_column)
    kwargs["columns"] = dataclasses.replace(columns, **changes)
    for key, value in (("time_unit", args.time_unit), ("fs_hz", args.fs_hz),
                       ("emg_unit", args.emg_unit), ("resample_hz", args.resample),
                       ("duplicates", args.duplicates)):
        if value is not None:
            kwargs[key] = value
    return kwargs
