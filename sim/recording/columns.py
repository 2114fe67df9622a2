"""Column maps: which columns of another tool's CSV hold time, sEMG and force.

A :class:`ColumnMap` names the columns; :func:`read_column_file` reads one, with the
other layout options, from a YAML or JSON file; :func:`resolve_columns` finds the
named columns in a CSV header. When the columns are not where the map says, the
error suggests the option to set (``RecordingError.fixes``),
from the header's names where it can guess (``timestamp`` for the time column).
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sim.recording.checks import (
    MAX_CSV_COLUMNS,
    MAX_SIDECAR_BYTES,
    OPTIONAL_COLUMNS,
    check_options,
    describe,
    json_object,
    positive_rate,
    read_text,
)
from sim.recording.errors import OPTIONS, Fix, RecordingError

_EMG_COLUMN = re.compile(r"^emg(\d+)$")
_EMG_RANGE = re.compile(r"^(.*?)(\d+)\.\.(.*?)(\d+)$")


@dataclass(frozen=True)
class ColumnMap:
    """Which CSV columns hold time, sEMG and force.

    Columns the map does not use are ignored (pandas' index column, labels,
    IMU data...). The default is griploop's own layout.

    Parameters
    ----------
    time : str or None
        Name of the time column (default ``"t"``); ``None`` when the file has
        none (then ``load_recording(..., fs_hz=...)`` gives the rate).
    emg : str, sequence of str, or None
        The sEMG columns, in channel order: a list of names, one string of
        comma-separated names, a glob (``"emg_*"``, file order) or a range of
        numbered names (``"emg_0..emg_7"`` or ``"emg_0..7"``). ``None``:
        griploop's ``emg1..emgN``. Named columns become the channel names.
    force : str or None
        Name of the measured-force column in newtons (default ``"force"``,
        optional when absent); ``None`` to load without force.
    """

    time: str | None = "t"
    emg: str | Sequence[str] | None = None
    force: str | None = "force"

    @property
    def is_default(self) -> bool:
        """Whether this is griploop's own layout."""
        return self == ColumnMap()

    def changed(self) -> list[str]:
        """The options (``time_column``, ``emg_columns``, ``force_column``) not at their default."""
        default = ColumnMap()
        return [option for option, attr in (("time_column", "time"), ("emg_columns", "emg"),
                                            ("force_column", "force"))
                if getattr(self, attr) != getattr(default, attr)]


def read_column_file(path: str | Path) -> dict[str, Any]:
    """Read a column-map file (YAML or JSON) into keyword arguments of ``load_recording``.

    The file is a mapping with any of the keys ``time_column``, ``emg_columns``,
    ``force_column`` (``null`` or ``"none"`` for no such column), ``time_unit``,
    ``fs_hz``, ``emg_unit``, ``resample_hz`` and ``duplicates``
    (:data:`~sim.recording.errors.OPTIONS`, named as the ``griploop evaluate``
    options)::

        time_column: timestamp
        time_unit: ms
        emg_columns: "emg_*"
        force_column: force_n
        resample_hz: 200

    Returns
    -------
    dict
        ``{"columns": ColumnMap, ...}`` with the file's other keys, ready for
        ``load_recording(path, **kwargs)``.

    Raises
    ------
    RecordingError
        Unreadable file, not a mapping, unknown key or a value of the wrong type.
    """
    path = Path(path)
    if not path.is_file():
        raise RecordingError(f"{path}: no such column-map file")
    data = _column_file_data(path)
    mapping: dict[str, Any] = {}
    for key, attr in (("time_column", "time"), ("force_column", "force")):
        if key in data:
            value = data[key]
            if value is not None and not isinstance(value, str):
                raise RecordingError(f"{path}: {key}: expected a column name, found "
                                     f"{describe(value)}")
            mapping[attr] = None if value is None or value.lower() == "none" else value
    if "emg_columns" in data:
        value = data["emg_columns"]
        if isinstance(value, list) and all(isinstance(v, str) for v in value):
            value = tuple(value)
        elif not isinstance(value, str):
            raise RecordingError(f"{path}: emg_columns: expected names, a glob or a range, "
                                 f"found {describe(value)}")
        mapping["emg"] = value
    kwargs: dict[str, Any] = {"columns": ColumnMap(**mapping)}
    for key in ("time_unit", "emg_unit", "duplicates"):
        if key in data:
            kwargs[key] = data[key]
    for key in ("fs_hz", "resample_hz"):
        if key in data:
            kwargs[key] = positive_rate(data[key], str(path), key)
    check_options(str(path), kwargs.get("time_unit", "s"), kwargs.get("emg_unit"),
                  kwargs.get("duplicates", "average"))
    return kwargs


def _column_file_data(path: Path) -> dict[str, Any]:
    """The column-map file parsed: a mapping whose keys are all layout options."""
    text = read_text(path, MAX_SIDECAR_BYTES, "column-map file")
    if path.suffix.lower() == ".json":
        data: Any = json_object(text, str(path), "column map")
    else:
        import yaml

        try:
            data = yaml.safe_load(text)
        except (yaml.YAMLError, RecursionError) as exc:
            reason = " ".join(str(exc).split())[:160]
            raise RecordingError(f"{path}: not valid YAML ({reason})") from None
    if not isinstance(data, dict):
        raise RecordingError(
            f"{path}: expected a mapping of {', '.join(OPTIONS)}, found {describe(data)}"
        )
    unknown = sorted(str(k) for k in data if k not in OPTIONS)
    if unknown:
        raise RecordingError(
            f"{path}: unknown key {unknown[0][:40]!r}; expected some of {', '.join(OPTIONS)}"
        )
    return data


# ----------------------------------------------------------------- columns of a header
def _suggest(names: list[str], pattern: str) -> str | None:
    """The first column whose lower-cased name matches ``pattern``, if any."""
    rx = re.compile(pattern)
    return next((n for n in names if rx.search(n.lower())), None)


def _shown(header: list[str]) -> str:
    text = ", ".join(repr(h[:20]) for h in header[:12])
    return text + (", ..." if len(header) > 12 else "")


def _glob_columns(text: str, header: list[str], path: Path) -> list[int]:
    """Header positions of the columns a glob matches, in file order."""
    found = [j for j, name in enumerate(header) if fnmatch.fnmatchcase(name, text)]
    if not found:
        raise RecordingError(
            f"{path}: sEMG columns {text!r} match no column; expected a glob matching some "
            f"of {_shown(header)}",
            option="emg_columns")
    return found


def _spec_names(text: str, path: Path) -> list[str]:
    """The column names of a spec string: comma-separated names, a range or one name."""
    if "," in text:
        return [s.strip() for s in text.split(",") if s.strip()]
    if ".." in text:
        m = _EMG_RANGE.match(text)
        if not m or (m.group(3) and m.group(3) != m.group(1)):
            raise RecordingError(
                f"{path}: sEMG columns {text!r}: expected a range like 'emg_0..emg_7' "
                "or 'emg_0..7'", option="emg_columns")
        lo, hi = int(m.group(2)), int(m.group(4))
        if hi < lo or hi - lo >= MAX_CSV_COLUMNS:
            raise RecordingError(
                f"{path}: sEMG columns {text!r}: expected first <= last and at most "
                f"{MAX_CSV_COLUMNS} channels", option="emg_columns")
        width = len(m.group(2)) if m.group(2).startswith("0") and len(m.group(2)) > 1 else 0
        return [f"{m.group(1)}{k:0{width}d}" for k in range(lo, hi + 1)]
    return [text] if text else []


def emg_spec_columns(spec: Any, header: list[str], path: Path) -> list[int]:
    """Header positions of the sEMG columns named by ``spec`` (names, glob or range).

    Raises
    ------
    RecordingError
        A spec of the wrong type, naming no column, a column twice, or a column
        the header lacks or holds twice (``option`` ``emg_columns``).
    """
    if isinstance(spec, str) and any(ch in spec for ch in "*?[") and "," not in spec:
        return _glob_columns(spec.strip(), header, path)
    if isinstance(spec, str):
        names = _spec_names(spec.strip(), path)
    elif isinstance(spec, (list, tuple)) and all(isinstance(s, str) for s in spec):
        names = list(spec)
    else:
        raise RecordingError(
            f"{path}: emg columns: expected names, a glob or a range, found {describe(spec)}"
        )
    if not names:
        raise RecordingError(f"{path}: the sEMG column list is empty; expected at least one "
                             "column", option="emg_columns")
    where: dict[str, int] = {}
    for j, name in enumerate(header):
        where.setdefault(name, j)
    missing = [n for n in names if n not in where]
    if missing:
        raise RecordingError(
            f"{path}: sEMG column {missing[0][:40]!r} not in the header; expected columns "
            f"among {_shown(header)}", option="emg_columns")
    if len(set(names)) != len(names):
        raise RecordingError(f"{path}: the sEMG column list names a column twice; expected "
                             "each column once", option="emg_columns")
    repeated = [n for n in names if header.count(n) > 1]
    if repeated:
        raise RecordingError(
            f"{path}: sEMG column {repeated[0][:40]!r} appears "
            f"{header.count(repeated[0])} times in the header (expected once); rename them or "
            "use a glob to take them all", option="emg_columns")
    return [where[n] for n in names]


class _Header:
    """A CSV header's names, for finding one column by name."""

    def __init__(self, names: list[str], path: Path) -> None:
        self.names = names
        self.path = path
        self.counts: dict[str, int] = {}
        for name in names:
            self.counts[name] = self.counts.get(name, 0) + 1

    def unique(self, name: str, option: str | None) -> int:
        """The position of column ``name``, refused when the header holds it twice."""
        if self.counts[name] > 1:
            raise RecordingError(
                f"{self.path}: column {name[:40]!r} appears {self.counts[name]} times; "
                "expected one: rename it" + (" or choose another column" if option else ""),
                fixes=[Fix.set(option)] if option else ())
        return self.names.index(name)


def _time_index(header: _Header, columns: ColumnMap, fs_hz: float | None) -> int | None:
    """Position of the time column, or None when the rate is given instead."""
    path, names = header.path, header.names
    if columns.time is not None:
        if columns.time in header.counts:
            return header.unique(columns.time, "time_column")
        if fs_hz is None or columns.time != "t":
            guess = _suggest(names, r"^(time|timestamp|t_|.*_t$|.*time)")
            raise RecordingError(
                f"{path}: no time column {columns.time[:40]!r} (columns: {_shown(names)})",
                fixes=[Fix.set("time_column", None if guess is None else guess[:40]),
                       Fix((("time_column", "none"), ("fs_hz", None)),
                           when="if the file has no time column")])
    elif fs_hz is None:
        raise RecordingError(f"{path}: no time column and no sampling rate",
                             fixes=[Fix.set("fs_hz")])
    return None


def _emg_indices(header: _Header, columns: ColumnMap) -> list[int]:
    """Positions of the sEMG columns, in channel order."""
    path, names = header.path, header.names
    if columns.emg is not None:
        return emg_spec_columns(columns.emg, names, path)
    emg_cols: list[tuple[int, int]] = []
    for j, name in enumerate(names):
        m = _EMG_COLUMN.match(name)
        if m:
            emg_cols.append((int(m.group(1)), j))
    if not emg_cols:
        guess = _suggest(names, r"emg|ch(an(nel)?)?[ _]?\d")
        stem = None if guess is None else re.sub(r"\d+$", "", guess)
        raise RecordingError(
            f"{path}: no sEMG columns emg1..emgN (columns: {_shown(names)}); "
            "expected names, a glob or a range of the sEMG columns",
            fixes=[Fix.set("emg_columns", f"{stem}*" if stem else None)])
    numbers = sorted(k for k, _ in emg_cols)
    if numbers != list(range(1, len(numbers) + 1)):
        raise RecordingError(
            f"{path}: sEMG columns must be emg1..emg{len(numbers)} without gaps or repeats, "
            f"found {[f'emg{k}' for k in numbers][:10]}", fixes=[Fix.set("emg_columns")])
    return [j for _, j in sorted(emg_cols)]


def _force_index(header: _Header, columns: ColumnMap, taken: list[int]) -> int | None:
    """Position of the force column, or None (no column ``force`` is not an error)."""
    path, names = header.path, header.names
    if columns.force is None:
        return None
    if columns.force in header.counts:
        return header.unique(columns.force, "force_column")
    if columns.force != "force":
        raise RecordingError(
            f"{path}: no force column {columns.force[:40]!r}; expected one of {_shown(names)}",
            option="force_column")
    guess = _suggest([h for j, h in enumerate(names) if j not in taken], r"force|fsr")
    if guess is not None:
        raise RecordingError(
            f"{path}: no column 'force' but found {guess[:40]!r}",
            fixes=[Fix.set("force_column", guess[:40]),
                   Fix.set("force_column", "none", when="to load without force")])
    return None


def resolve_columns(
    names: list[str], columns: ColumnMap, path: Path, fs_hz: float | None
) -> tuple[int | None, list[int], int | None, dict[str, int]]:
    """Positions of the time, sEMG, force and ground-truth columns in a CSV header.

    Parameters
    ----------
    names : list of str
        The header's column names.
    columns : ColumnMap
        Where the columns are.
    path : Path
        The file, for messages.
    fs_hz : float or None
        The sampling rate given, which makes a missing default time column ``t`` fine.

    Returns
    -------
    time : int or None
    emg : list of int
    force : int or None
    extra : dict
        Positions of the simulated ground truth (``intent``, ``intent_force_n``), the
        forearm pitch (``pitch_rad``) and the open label (``open_intent``) found by
        griploop's names and otherwise unused.

    Raises
    ------
    RecordingError
        A column missing, held twice by the header, or used twice.
    """
    header = _Header(names, path)
    t_idx = _time_index(header, columns, fs_hz)
    emg_idx = _emg_indices(header, columns)
    if t_idx is not None and t_idx in emg_idx:
        raise RecordingError(f"{path}: column {names[t_idx]!r} is both time and sEMG; expected "
                             "different columns")
    f_idx = _force_index(header, columns, emg_idx)
    if f_idx is not None and (f_idx in emg_idx or f_idx == t_idx):
        raise RecordingError(f"{path}: column {columns.force!r} is used twice; expected the "
                             "force column apart from time and sEMG")
    used = set(emg_idx) | {t_idx, f_idx}
    extra: dict[str, int] = {}
    for name in OPTIONAL_COLUMNS:
        if name in header.counts and names.index(name) not in used:
            extra[name] = header.unique(name, None)
    return t_idx, emg_idx, f_idx, extra
