"""Command-line options that tell the recording loader another tool's CSV layout.

Shared by the commands that read a recording (``evaluate``, ``plot-recording``,
``stream``, ``live``): :func:`add_recording_options` declares them,
:func:`recording_kwargs` turns the parsed arguments into keyword arguments of
:func:`sim.recording.load_recording`, and :func:`load_with_options` loads a file
with them. A ``--columns`` file gives defaults; options on the command line win.

The library names its layout options as a column-map file does (``time_unit``,
``resample_hz``); a :class:`~sim.recording.RecordingError` carries the option at
fault and the fixes as data, and :func:`flag_message` says them as this command
line's flags (``pass --time-unit ms``), from :data:`FLAGS`.
"""

from __future__ import annotations

import argparse
import dataclasses
import shlex
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sim.recording import (
    DUPLICATES,
    EMG_UNITS,
    TIME_UNITS,
    ColumnMap,
    RecordingError,
    load_recording,
    read_column_file,
)

if TYPE_CHECKING:
    from sim.recording import Fix, Recording

#: Layout option of the library (:data:`sim.recording.errors.OPTIONS`) -> (flag, metavar).
FLAGS: dict[str, tuple[str, str]] = {
    "time_column": ("--time-column", "NAME"),
    "emg_columns": ("--emg-columns", "SPEC"),
    "force_column": ("--force-column", "NAME"),
    "time_unit": ("--time-unit", "UNIT"),
    "fs_hz": ("--fs-hz", "HZ"),
    "emg_unit": ("--emg-unit", "UNIT"),
    "resample_hz": ("--resample", "HZ"),
    "duplicates": ("--duplicates", "RULE"),
}


def add_recording_options(parser: argparse.ArgumentParser) -> None:
    """Declare the layout options on ``parser`` (in their own help group)."""
    group = parser.add_argument_group(
        "recording layout (CSV from other tools; see docs/FORMAT.md)"
    )
    group.add_argument("--columns", metavar="FILE",
                       help="column map (.yaml or .json) with any of time_column, emg_columns, "
                       "force_column, time_unit, fs_hz, emg_unit, resample_hz, duplicates; "
                       "options given here win")
    _add(group, "time_column",
         help="time column (default: t); 'none' if the file has none "
         "(then give --fs-hz)")
    _add(group, "emg_columns",
         help="sEMG columns in channel order: names 'a,b,c', a glob 'emg_*' "
         "(file order) or a range 'emg_0..emg_7' (default: emg1..emgN)")
    _add(group, "force_column",
         help="measured force column in newtons (default: force); 'none' to "
         "load without force")
    _add(group, "time_unit", choices=TIME_UNITS,
         help="unit of the time column (default: s)")
    _add(group, "fs_hz", type=float,
         help="sampling rate when the file has no time column")
    _add(group, "emg_unit", choices=EMG_UNITS,
         help="unit of the sEMG columns (default: int8 if every value is an "
         "integer in -128..127, else uV)")
    _add(group, "resample_hz", type=float,
         help="interpolate sEMG and force onto a uniform HZ grid, for jittered "
         "or duplicated time stamps (MYO dumps)")
    _add(group, "duplicates", choices=DUPLICATES,
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


def load_with_options(path: str | Path, args: argparse.Namespace) -> Recording:
    """``load_recording(path)`` with the layout options of ``args``.

    Raises
    ------
    RecordingError
        As ``load_recording``, its message naming this command line's flags
        (:func:`flag_message`).
    """
    try:
        return load_recording(path, **recording_kwargs(args))
    except RecordingError as exc:
        raise RecordingError(flag_message(exc)) from exc


def flag_message(exc: RecordingError) -> str:
    """The error's message with its option and fixes said as flags.

    ``"...: time column 't' in ms? found steps of 10 s (...); pass --time-unit ms"``,
    ``"...: resampling needs a time column (found none) (option --resample)"``.
    """
    return exc.detail + exc.hint(lambda option: FLAGS[option][0], _fix_flags, "pass")


def _add(group: argparse._ArgumentGroup, option: str, **kwargs: Any) -> None:
    """Declare a layout option by its flag (:data:`FLAGS`; its metavar unless it has choices)."""
    flag, metavar = FLAGS[option]
    if "choices" not in kwargs:
        kwargs["metavar"] = metavar
    group.add_argument(flag, **kwargs)


def _fix_flags(fix: Fix) -> str:
    """A fix as flags: ``--time-column none --fs-hz HZ if the file has no time column``."""
    words = []
    for option, value in fix.settings:
        flag, metavar = FLAGS[option]
        words += [flag, metavar if value is None else shlex.quote(value)]
    return " ".join(words) + (f" {fix.when}" if fix.when else "")
