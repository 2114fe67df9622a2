"""Units, limits and the value checks every part of the recording package shares.

The limits bound what a file may make griploop allocate or believe (a grip force of
1e300 N, a sampling rate of 0 Hz); the checks raise
:class:`~sim.recording.errors.RecordingError` naming
the source and the field.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from sim.recording.errors import RecordingError

EMG_UNITS = ("int8", "uV", "mV", "a.u.")
TIME_UNITS = ("s", "ms", "us")
#: Seconds per unit of a CSV time column.
TIME_UNIT_S = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
DUPLICATES = ("average", "spread")
#: Optional per-sample columns written and read by name: the simulated ground truth
#: (``intent``, ``intent_force_n``), the forearm's pitch from an armband's IMU and the
#: open-contraction label of a calibration for a hand that opens on a second signal.
OPTIONAL_COLUMNS = ("intent", "intent_force_n", "pitch_rad", "open_intent")
MIN_FS_HZ = 10.0
"""Lowest sampling rate a CSV time column may imply, Hz (lower means a wrong time unit)."""
MAX_GAP_STEPS = 20
"""Largest gap resampling bridges, in median time steps (longer gaps are refused)."""
MAX_SIDECAR_BYTES = 16 * 2**20
"""Largest JSON sidecar or column-map file, bytes."""
MAX_FORCE_N = 1e4
"""Largest grip force a recording may hold, N (a hand squeezes a few hundred at most)."""
MAX_INTENT = 10.0
"""Largest normalized intent (0..1 of MVC; 10 leaves room for calibration error)."""
MAX_PITCH_RAD = float(np.pi)
"""Largest forearm pitch magnitude a recording may hold, rad."""
MAX_EMG_ABS = 1e9
"""Largest float sEMG magnitude in any unit."""
MAX_FS_HZ = 1e6
"""Highest sampling rate accepted, Hz."""
MAX_FILE_BYTES = 256 * 2**20
"""Default cap on a recording's size: the file (CSV) or its arrays uncompressed (NPZ)."""
MAX_CSV_COLUMNS = 1 + 256 + 4
"""Widest CSV accepted: t, up to 256 sEMG channels, force, ground truth and pitch."""


def positive_rate(value: Any, src: str, field: str, *, option: str | None = None) -> float:
    """``value`` as a finite sampling rate in (0, MAX_FS_HZ] Hz.

    Parameters
    ----------
    value : object
        The rate as given (a number, a 1-element numeric array...).
    src : str
        The source, for the message.
    field : str
        What the value is, for the message (``"fs_hz"``, ``"sampling rate"``).
    option : str, optional
        The layout option it came from (``RecordingError.option``).

    Raises
    ------
    RecordingError
        Not a real number, or not in (0, MAX_FS_HZ].
    """
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in "iuf":
        value = value.reshape(()).item()
    elif isinstance(value, np.generic) and value.dtype.kind in "iuf":
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RecordingError(
            f"{src}: {field}: expected a positive number of hertz, found {describe(value)}",
            option=option)
    rate = float(value)
    if not (np.isfinite(rate) and 0 < rate <= MAX_FS_HZ):
        raise RecordingError(
            f"{src}: {field}: expected a positive number of hertz up to {MAX_FS_HZ:g}, "
            f"found {value!r}", option=option)
    return rate


def describe(value: Any) -> str:
    """A short description of a value of the wrong kind: its type and (cut) repr."""
    if isinstance(value, np.ndarray):
        return f"array of dtype {value.dtype} and shape {value.shape}"
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


def check_options(src: str, time_unit: Any, emg_unit: Any, duplicates: Any) -> None:
    """Refuse a time unit, sEMG unit or duplicates rule outside its choices."""
    for label, value, allowed in (("time_unit", time_unit, TIME_UNITS),
                                  ("emg_unit", emg_unit, (None, *EMG_UNITS)),
                                  ("duplicates", duplicates, DUPLICATES)):
        if not isinstance(value, (str, type(None))) or value not in allowed:
            shown = ", ".join(str(a) for a in allowed if a is not None)
            raise RecordingError(f"{src}: {label}: expected one of {shown}, found "
                                 f"{describe(value)}")


def read_text(path: Path, max_bytes: int, what: str = "file") -> str:
    """A UTF-8 text file (a BOM is dropped), refused when larger than ``max_bytes``."""
    size = path.stat().st_size
    if size > max_bytes:
        raise RecordingError(
            f"{path}: {what} of {size} bytes (expected at most {max_bytes}); "
            "raise max_bytes to load it"
        )
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RecordingError(
            f"{path}: not UTF-8 text (byte {exc.start}: {exc.reason})"
        ) from None
    if "\0" in text:
        raise RecordingError(f"{path}: contains NUL bytes (expected {what} text)")
    return text


def json_object(text: str, src: str, field: str) -> dict[str, Any]:
    """``text`` parsed as a JSON object."""
    try:
        meta = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        raise RecordingError(f"{src}: corrupt {field} (not valid JSON)") from None
    if not isinstance(meta, dict):
        raise RecordingError(
            f"{src}: {field}: expected a JSON object, found {type(meta).__name__}"
        )
    return meta
