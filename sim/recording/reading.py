"""Reading a recording file: :func:`load_recording` and the hardened NPZ reader.

:func:`load_recording` checks its options, then reads an ``.npz`` here or a
``.csv`` through :mod:`sim.recording.csv_import`. Whatever the file holds, the
only exception that escapes is :class:`~sim.recording.errors.RecordingError`,
and loads are bounded: an NPZ file's arrays are checked against their zip
headers (declared sizes, dtypes; no pickles) before anything is decompressed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from sim.recording.checks import (
    MAX_FILE_BYTES,
    check_options,
    describe,
    positive_rate,
)
from sim.recording.columns import ColumnMap
from sim.recording.core import Recording
from sim.recording.csv_import import load_csv
from sim.recording.errors import Fix, RecordingError

_NPZ_ARRAYS = ("emg", "fs_hz", "channel_names", "emg_unit", "metadata_json", "force_n",
               "intent", "intent_force_n", "pitch_rad", "open_intent")
#: What each CSV-only option is, for the message refusing it for an NPZ file.
_CSV_ONLY = {"time_column": "time column", "emg_columns": "sEMG column list",
             "force_column": "force column", "time_unit": "time unit",
             "fs_hz": "sampling rate", "resample_hz": "resampling rate",
             "emg_unit": "sEMG unit", "duplicates": "duplicates rule"}


def load_recording(
    path: str | Path,
    *,
    columns: ColumnMap | None = None,
    time_unit: str = "s",
    fs_hz: float | None = None,
    resample_hz: float | None = None,
    duplicates: str = "average",
    emg_unit: str | None = None,
    max_bytes: int = MAX_FILE_BYTES,
) -> Recording:
    """Load a recording from ``.npz`` or ``.csv``.

    Parameters
    ----------
    path : str or Path
        The file. A CSV needs a header line; by default its columns are
        griploop's ``t,emg1..emgN[,force]`` and other columns are ignored.
        Metadata come from ``FILE.csv.json`` or an old ``# griploop {json}``
        first line (which wins) when present.
    columns : ColumnMap, optional
        Which CSV columns hold time, sEMG and force (CSV only).
    time_unit : {"s", "ms", "us"}
        Unit of the CSV time column.
    fs_hz : float, optional
        Sampling rate, Hz, for a CSV without a time column
        (``ColumnMap(time=None)``, or the default ``t`` absent). With a time
        column it must agree with it within 1 %.
    resample_hz : float, optional
        Interpolate sEMG and force linearly (``numpy.interp``) onto a uniform
        grid at this rate starting at the first time stamp: for jittered or
        duplicated time stamps. No anti-alias filter is applied, so choose a
        rate at or above the device's. Gaps longer than ``MAX_GAP_STEPS``
        median steps are refused. int8 sEMG is rounded back to counts.
    duplicates : {"average", "spread"}
        With ``resample_hz``: rows sharing a time stamp are averaged into one
        sample (default), or spread evenly up to the next stamp (MYO dumps,
        where one packet stamp covers several consecutive samples).
    emg_unit : str, optional
        Unit of the CSV sEMG columns; wins over the metadata. Default: the
        metadata's, else ``"int8"`` when every value is an integer within
        -128..127, otherwise ``"uV"``.
    max_bytes : int
        Largest CSV file (and resampled data), or largest total of an NPZ
        file's arrays uncompressed (as their zip headers declare, checked
        before anything is decompressed), bytes.

    Raises
    ------
    RecordingError
        The only exception: missing or unreadable file, unknown format,
        oversized file or array, NaN/inf, values outside the unit's range,
        missing columns, decreasing, duplicated or irregular time without
        ``resample_hz``, an implausible time unit, a metadata sampling rate
        contradicting the time column. The message names the file, the field
        and what was expected; the layout option at fault and the options that
        would fix it are also attributes (``option``, ``fixes``) for a front end
        to name in its own terms.
    """
    path = Path(path)
    columns = ColumnMap() if columns is None else columns
    fs_hz, resample_hz = _checked_options(path, columns, time_unit, fs_hz, resample_hz,
                                          duplicates, emg_unit)
    try:
        if path.suffix == ".npz":
            return _load_npz(path, max_bytes)
        return load_csv(path, emg_unit, max_bytes, columns, time_unit, fs_hz, resample_hz,
                        duplicates)
    except RecordingError:
        raise
    except MemoryError:
        raise RecordingError(f"{path}: too large to load in memory") from None
    except Exception as exc:  # never let a malformed file escape as another type
        text = " ".join(str(exc).split())[:200]
        raise RecordingError(
            f"{path}: unreadable recording ({type(exc).__name__}: {text})"
        ) from None


def _checked_options(path: Path, columns: Any, time_unit: Any, fs_hz: Any, resample_hz: Any,
                     duplicates: Any, emg_unit: Any) -> tuple[float | None, float | None]:
    """Refuse options of the wrong kind, or that do not apply to the file; the rates as floats."""
    if not isinstance(columns, ColumnMap):
        raise RecordingError(f"{path}: columns: expected a ColumnMap, found {describe(columns)}")
    check_options(str(path), time_unit, emg_unit, duplicates)
    if not path.exists():
        raise RecordingError(f"{path}: no such file")
    if not path.is_file():
        raise RecordingError(f"{path}: not a regular file (expected a .npz or .csv recording)")
    if path.suffix not in (".npz", ".csv"):
        raise RecordingError(
            f"{path}: unknown recording format {path.suffix!r}; expected .npz or .csv"
        )
    if path.suffix == ".npz":
        given = columns.changed() + [option for option, value, default in (
            ("time_unit", time_unit, "s"), ("fs_hz", fs_hz, None),
            ("resample_hz", resample_hz, None), ("emg_unit", emg_unit, None),
            ("duplicates", duplicates, "average")) if value != default]
        if given:
            raise RecordingError(
                f"{path}: the {_CSV_ONLY[given[0]]} applies to CSV files only (an NPZ "
                "recording carries its own layout and rate)", option=given[0])
    if duplicates != "average" and resample_hz is None:
        raise RecordingError(
            f"{path}: the duplicates rule {duplicates!r} applies when resampling only "
            "(found no resampling rate)", option="duplicates", fixes=[Fix.set("resample_hz")])
    if fs_hz is not None:
        fs_hz = positive_rate(fs_hz, str(path), "sampling rate", option="fs_hz")
    if resample_hz is not None:
        resample_hz = positive_rate(resample_hz, str(path), "resampling rate",
                                    option="resample_hz")
    return fs_hz, resample_hz


def _load_npz(path: Path, max_bytes: int) -> Recording:
    import zipfile

    try:
        archive = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError) as exc:
        raise RecordingError(
            f"{path}: not an NPZ file (expected a zip archive of .npy arrays; found: {exc})"
        ) from None
    with archive:
        infos = archive.infolist()
        names = [info.filename.removesuffix(".npy") for info in infos]
        odd = [info.filename for info in infos if not info.filename.endswith(".npy")]
        if odd:
            raise RecordingError(f"{path}: member {odd[0]!r} is not a .npy array")
        extra = sorted(set(names) - set(_NPZ_ARRAYS))
        if extra:
            raise RecordingError(
                f"{path}: unknown arrays {extra}; expected a subset of {sorted(_NPZ_ARRAYS)}"
            )
        dup = [k for k in set(names) if names.count(k) > 1]
        if dup:
            raise RecordingError(f"{path}: array {dup[0]!r} appears twice")
        for key in ("emg", "fs_hz"):
            if key not in names:
                raise RecordingError(f"{path}: missing array {key!r}")
        declared = sum(info.file_size for info in infos)
        if declared > max_bytes:
            raise RecordingError(
                f"{path}: arrays declare {declared} bytes uncompressed "
                f"(expected at most {max_bytes}); raise max_bytes to load it"
            )
        arrays = {
            name: _read_member(archive, info, path, name)
            for name, info in zip(names, infos, strict=True)
        }
    fs_hz = positive_rate(arrays["fs_hz"], str(path), "fs_hz")
    emg = arrays["emg"]
    if emg.ndim == 2 and emg.shape[0] < 2:
        raise RecordingError(
            f"{path}: emg: expected at least 2 samples, found shape {emg.shape}"
        )
    return Recording(
        emg=emg,
        fs_hz=fs_hz,
        force_n=arrays.get("force_n"),
        channel_names=_npz_names(arrays["channel_names"], path)
        if "channel_names" in arrays else None,
        emg_unit=_npz_text(arrays["emg_unit"], path, "emg_unit")
        if "emg_unit" in arrays else "int8",
        intent=arrays.get("intent"),
        intent_force_n=arrays.get("intent_force_n"),
        pitch_rad=arrays.get("pitch_rad"),
        open_intent=arrays.get("open_intent"),
        metadata=_npz_metadata(arrays["metadata_json"], path)
        if "metadata_json" in arrays else {},
        source=str(path),
    )


def _read_member(archive: Any, info: Any, path: Path, name: str) -> np.ndarray:
    """One ``.npy`` member, its header checked against the zip header before reading."""
    fmt = np.lib.format
    try:
        with archive.open(info) as fp:
            version = fmt.read_magic(fp)
            if version == (1, 0):
                shape, fortran, dtype = fmt.read_array_header_1_0(fp)
            else:
                shape, fortran, dtype = fmt.read_array_header_2_0(fp)
            header_len = fp.tell()
    except Exception as exc:
        raise RecordingError(f"{path}: {name}: not a .npy array ({exc})") from None
    if dtype.hasobject or dtype.kind not in "biufU":
        raise RecordingError(
            f"{path}: {name}: expected a numeric or text array, found dtype {dtype}"
        )
    count = 1
    for dim in shape:
        count *= int(dim)
    nbytes = count * dtype.itemsize
    if header_len + nbytes != info.file_size:
        raise RecordingError(
            f"{path}: {name}: header declares shape {shape} of {dtype} ({nbytes} bytes) "
            f"but the member holds {info.file_size - header_len} bytes"
        )
    try:
        with archive.open(info) as fp:
            return fmt.read_array(fp, allow_pickle=False)
    except Exception as exc:
        raise RecordingError(f"{path}: {name}: unreadable array ({exc})") from None


def _npz_text(value: np.ndarray, path: Path, field: str) -> str:
    if value.dtype.kind != "U" or value.size != 1:
        raise RecordingError(f"{path}: {field}: expected one string, found {describe(value)}")
    return str(value.reshape(()))


def _npz_names(value: np.ndarray, path: Path) -> list[str]:
    if value.dtype.kind != "U" or value.ndim != 1:
        raise RecordingError(
            f"{path}: channel_names: expected a 1-D array of strings, found {describe(value)}"
        )
    return [str(s) for s in value]


def _npz_metadata(value: np.ndarray, path: Path) -> dict[str, Any]:
    text = _npz_text(value, path, "metadata_json")
    try:
        meta = json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise RecordingError(f"{path}: metadata_json: not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise RecordingError(
            f"{path}: metadata_json: expected a JSON object, found {type(meta).__name__}"
        )
    return meta

