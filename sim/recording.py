"""One sEMG + force recording, simulated or real, and its NPZ/CSV file formats.

A :class:`Recording` is what a MYO armband and an FSR produce in one session:
multichannel sEMG of shape ``(n_samples, n_channels)`` sampled at ``fs_hz``, the
measured grip force in newtons (optional), and, for simulated subjects, the
ground-truth intent (normalized force, 0..1) that produced them.

CSV layout written by griploop (one header line, one row per sample)::

    t,emg1,emg2,...,emg8,force
    0.000000,3,-1,...,0,0.512

``t`` is in seconds; channel columns are named ``emg1..emgN`` (1-based, as on the
MYO); ``force`` is in newtons; optional ``intent`` and ``intent_force_n`` carry the
simulated ground truth. Metadata (rate, sEMG unit, channel names, provenance) go to
the JSON sidecar ``FILE.csv.json``. The older form with a ``# griploop {json}``
first line is still read.

Other tools' CSV files are read through a :class:`ColumnMap` (which columns hold
time, sEMG and force), a time unit or a sampling rate, and an optional resampling
onto a uniform grid; columns the map does not use are ignored. ``docs/FORMAT.md``
documents the formats and options.
"""

from __future__ import annotations

import fnmatch
import json
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sim.errors import GriploopError

EMG_UNITS = ("int8", "uV", "mV", "a.u.")
_OPTIONAL_COLUMNS = ("intent", "intent_force_n")
_EMG_COLUMN = re.compile(r"^emg(\d+)$")
_EMG_RANGE = re.compile(r"^(.*?)(\d+)\.\.(.*?)(\d+)$")
TIME_UNITS = ("s", "ms", "us")
_TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
DUPLICATES = ("average", "spread")
MIN_FS_HZ = 10.0
"""Lowest sampling rate a CSV time column may imply, Hz (lower means a wrong time unit)."""
MAX_GAP_STEPS = 20
"""Largest gap resampling bridges, in median time steps (longer gaps are refused)."""
MAX_SIDECAR_BYTES = 16 * 2**20
"""Largest JSON sidecar or column-map file, bytes."""
# Relative tolerance on sample-interval regularity of the time column.
_TIME_RTOL = 1e-3
# Relative tolerance between a metadata sampling rate and the time column's.
_RATE_RTOL = 1e-2
MAX_FORCE_N = 1e4
"""Largest grip force a recording may hold, N (a hand squeezes a few hundred at most)."""
MAX_INTENT = 10.0
"""Largest normalized intent (0..1 of MVC; 10 leaves room for calibration error)."""
MAX_EMG_ABS = 1e9
"""Largest float sEMG magnitude in any unit."""
MAX_FS_HZ = 1e6
"""Highest sampling rate accepted, Hz."""
MAX_FILE_BYTES = 256 * 2**20
"""Default cap on a recording's size: the file (CSV) or its arrays uncompressed (NPZ)."""
MAX_CSV_COLUMNS = 1 + 256 + 3
"""Widest CSV accepted: t, up to 256 sEMG channels, force and ground truth."""
_NPZ_ARRAYS = ("emg", "fs_hz", "channel_names", "emg_unit", "metadata_json", "force_n",
               "intent", "intent_force_n")


class RecordingError(GriploopError, ValueError):
    """A recording file or array is malformed.

    The message names the source (file or argument), the column or field and
    what was expected versus what was found.
    """


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


_LAYOUT_KEYS = ("time_column", "emg_columns", "force_column", "time_unit", "fs_hz",
                "emg_unit", "resample_hz", "duplicates")


def read_column_file(path: str | Path) -> dict[str, Any]:
    """Read a column-map file (YAML or JSON) into keyword arguments of :func:`load_recording`.

    The file is a mapping with any of the keys ``time_column``, ``emg_columns``,
    ``force_column`` (``null`` or ``"none"`` for no such column), ``time_unit``,
    ``fs_hz``, ``emg_unit``, ``resample_hz`` and ``duplicates``, named as the
    ``griploop evaluate`` options::

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
    text = _read_text(path, MAX_SIDECAR_BYTES, "column-map file")
    if path.suffix.lower() == ".json":
        data: Any = _json_object(text, str(path), "column map")
    else:
        import yaml

        try:
            data = yaml.safe_load(text)
        except (yaml.YAMLError, RecursionError) as exc:
            reason = " ".join(str(exc).split())[:160]
            raise RecordingError(f"{path}: not valid YAML ({reason})") from None
    if not isinstance(data, dict):
        raise RecordingError(
            f"{path}: expected a mapping of {', '.join(_LAYOUT_KEYS)}, found {_describe(data)}"
        )
    unknown = sorted(str(k) for k in data if k not in _LAYOUT_KEYS)
    if unknown:
        raise RecordingError(
            f"{path}: unknown key {unknown[0][:40]!r}; expected some of {', '.join(_LAYOUT_KEYS)}"
        )
    mapping: dict[str, Any] = {}
    for key, attr in (("time_column", "time"), ("force_column", "force")):
        if key in data:
            value = data[key]
            if value is not None and not isinstance(value, str):
                raise RecordingError(f"{path}: {key}: expected a column name, found "
                                     f"{_describe(value)}")
            mapping[attr] = None if value is None or value.lower() == "none" else value
    if "emg_columns" in data:
        value = data["emg_columns"]
        if isinstance(value, list) and all(isinstance(v, str) for v in value):
            value = tuple(value)
        elif not isinstance(value, str):
            raise RecordingError(f"{path}: emg_columns: expected names, a glob or a range, "
                                 f"found {_describe(value)}")
        mapping["emg"] = value
    kwargs: dict[str, Any] = {"columns": ColumnMap(**mapping)}
    for key in ("time_unit", "emg_unit", "duplicates"):
        if key in data:
            kwargs[key] = data[key]
    if "fs_hz" in data:
        kwargs["fs_hz"] = _positive_rate(data["fs_hz"], str(path), "fs_hz")
    if "resample_hz" in data:
        kwargs["resample_hz"] = _positive_rate(data["resample_hz"], str(path), "resample_hz")
    _check_options(str(path), kwargs.get("time_unit", "s"), kwargs.get("emg_unit"),
                   kwargs.get("duplicates", "average"))
    return kwargs


def _check_options(src: str, time_unit: Any, emg_unit: Any, duplicates: Any) -> None:
    for label, value, allowed in (("time_unit", time_unit, TIME_UNITS),
                                  ("emg_unit", emg_unit, (None, *EMG_UNITS)),
                                  ("duplicates", duplicates, DUPLICATES)):
        if not isinstance(value, (str, type(None))) or value not in allowed:
            shown = ", ".join(str(a) for a in allowed if a is not None)
            raise RecordingError(f"{src}: {label}: expected one of {shown}, found "
                                 f"{_describe(value)}")


def sidecar_path(csv_path: str | Path) -> Path:
    """The JSON sidecar of a CSV recording: ``FILE.csv`` -> ``FILE.csv.json``."""
    csv_path = Path(csv_path)
    return csv_path.with_name(csv_path.name + ".json")


@dataclass
class Recording:
    """Multichannel sEMG with measured force and optional ground truth.

    Parameters
    ----------
    emg : ndarray, shape (n_samples, n_channels)
        Raw sEMG. For MYO-like data ``int8`` counts (-128..127, no physical
        unit); real recordings may be float microvolts (set ``emg_unit``).
    fs_hz : float
        Sampling rate of ``emg`` and ``force_n`` in hertz.
    force_n : ndarray, shape (n_samples,), optional
        Measured grip force in newtons (the FSR reading).
    channel_names : list of str, optional
        One name per channel; default ``["emg1", ..., "emgN"]``.
    emg_unit : {"int8", "uV", "mV", "a.u."}
        Unit of ``emg``.
    intent : ndarray, shape (n_samples,), optional
        Ground-truth intended grip force, normalized to 0..1 of MVC
        (simulated recordings only).
    intent_force_n : ndarray, shape (n_samples,), optional
        Ground-truth muscle grip force in newtons (simulated recordings only),
        before the force sensor.
    metadata : dict
        JSON-serializable provenance (subject id, seed, generator, muscles...).
    """

    emg: np.ndarray
    fs_hz: float
    force_n: np.ndarray | None = None
    channel_names: list[str] | None = None
    emg_unit: str = "int8"
    intent: np.ndarray | None = None
    intent_force_n: np.ndarray | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    source: str = "<array>"

    def __post_init__(self) -> None:
        src = self.source
        emg = np.asarray(self.emg)
        if emg.ndim != 2:
            raise RecordingError(
                f"{src}: emg must be 2-D (n_samples, n_channels), found shape {emg.shape}"
            )
        n, c = emg.shape
        if n == 0 or c == 0:
            raise RecordingError(f"{src}: emg is empty, shape {emg.shape}")
        self.fs_hz = _positive_rate(self.fs_hz, src, "fs_hz")
        if emg.dtype.kind not in "iuf":
            raise RecordingError(f"{src}: emg must be numeric, found dtype {emg.dtype}")
        if emg.dtype.kind == "f" and not np.all(np.isfinite(emg)):
            bad = int(np.argwhere(~np.isfinite(emg))[0][1])
            raise RecordingError(
                f"{src}: column emg{bad + 1} contains NaN or inf; expected finite values"
            )
        if not isinstance(self.emg_unit, str) or self.emg_unit not in EMG_UNITS:
            raise RecordingError(
                f"{src}: emg_unit must be one of {EMG_UNITS}, found {self.emg_unit!r}"
            )
        if self.emg_unit == "int8" and emg.dtype != np.int8:
            lo, hi = emg.min(), emg.max()
            if lo < -128 or hi > 127 or not np.array_equal(emg, np.round(emg)):
                raise RecordingError(
                    f"{src}: emg: expected int8 counts (integers in -128..127) for emg_unit "
                    f"int8, found values in {float(lo):.6g}..{float(hi):.6g}"
                )
        elif emg.dtype.kind == "f" and float(np.max(np.abs(emg))) > MAX_EMG_ABS:
            raise RecordingError(
                f"{src}: emg: expected |values| <= {MAX_EMG_ABS:g} {self.emg_unit}, "
                f"found {float(np.max(np.abs(emg))):.6g}"
            )
        self.emg = emg
        if self.channel_names is None:
            self.channel_names = [f"emg{i + 1}" for i in range(c)]
        else:
            if isinstance(self.channel_names, (str, bytes)) or not hasattr(
                self.channel_names, "__len__"
            ):
                raise RecordingError(
                    f"{src}: channel_names: expected a list of {c} names, "
                    f"found {type(self.channel_names).__name__}"
                )
            if len(self.channel_names) != c:
                raise RecordingError(
                    f"{src}: {len(self.channel_names)} channel names for {c} channels"
                )
            self.channel_names = [str(name) for name in self.channel_names]
        for name in ("force_n", "intent", "intent_force_n"):
            value = getattr(self, name)
            if value is None:
                continue
            raw = np.asarray(value)
            if raw.dtype.kind not in "iuf":
                raise RecordingError(
                    f"{src}: {name}: expected real numbers, found dtype {raw.dtype}"
                )
            arr = raw.astype(float)
            if arr.shape != (n,):
                raise RecordingError(
                    f"{src}: {name} must have shape ({n},) to match emg, found {arr.shape}"
                )
            if not np.all(np.isfinite(arr)):
                raise RecordingError(f"{src}: column {name} contains NaN or inf")
            limit = MAX_INTENT if name == "intent" else MAX_FORCE_N
            peak = float(np.max(np.abs(arr)))
            if peak > limit:
                unit = "" if name == "intent" else " N"
                raise RecordingError(
                    f"{src}: {name}: expected |values| <= {limit:g}{unit}, found {peak:.6g}"
                )
            setattr(self, name, arr)
        if not isinstance(self.metadata, dict):
            raise RecordingError(
                f"{src}: metadata: expected a JSON object, found {type(self.metadata).__name__}"
            )

    # ------------------------------------------------------------------ basics
    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.emg.shape[0])

    @property
    def n_channels(self) -> int:
        """Number of sEMG channels."""
        return int(self.emg.shape[1])

    @property
    def duration_s(self) -> float:
        """Duration in seconds (``n_samples / fs_hz``)."""
        return self.n_samples / self.fs_hz

    @property
    def t_s(self) -> np.ndarray:
        """Sample times in seconds, shape (n_samples,)."""
        return np.arange(self.n_samples) / self.fs_hz

    def channel_index(self, channel: int | str) -> int:
        """Zero-based column of a channel given as a 1-based number or a name.

        Raises
        ------
        RecordingError
            If the channel does not exist.
        """
        if isinstance(channel, str) and channel in self.channel_names:
            return self.channel_names.index(channel)
        if isinstance(channel, (int, np.integer)) and 1 <= int(channel) <= self.n_channels:
            return int(channel) - 1
        raise RecordingError(
            f"{self.source}: unknown channel {channel!r}; expected 1..{self.n_channels} "
            f"or one of {self.channel_names}"
        )

    def slice(self, start: int, stop: int) -> Recording:
        """A new recording holding samples ``start:stop``."""

        def cut(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else a[start:stop]

        return Recording(
            emg=self.emg[start:stop],
            fs_hz=self.fs_hz,
            force_n=cut(self.force_n),
            channel_names=list(self.channel_names),
            emg_unit=self.emg_unit,
            intent=cut(self.intent),
            intent_force_n=cut(self.intent_force_n),
            metadata=dict(self.metadata),
            source=self.source,
        )

    # --------------------------------------------------------------- file I/O
    def save(self, path: str | Path) -> Path:
        """Save as ``.npz`` or ``.csv`` according to the file suffix."""
        path = Path(path)
        if path.suffix == ".npz":
            return self.save_npz(path)
        if path.suffix == ".csv":
            return self.save_csv(path)
        raise RecordingError(f"{path}: unknown recording format; expected .npz or .csv")

    def save_npz(self, path: str | Path) -> Path:
        """Save losslessly (dtypes kept) as a compressed NPZ file."""
        path = Path(path)
        arrays: dict[str, Any] = {
            "emg": self.emg,
            "fs_hz": np.float64(self.fs_hz),
            "channel_names": np.array(self.channel_names),
            "emg_unit": np.array(self.emg_unit),
            "metadata_json": np.array(json.dumps(self.metadata, sort_keys=True)),
        }
        for name in ("force_n", "intent", "intent_force_n"):
            value = getattr(self, name)
            if value is not None:
                arrays[name] = value
        np.savez_compressed(path, **arrays)
        return path

    def save_csv(self, path: str | Path) -> Path:
        """Save as plain CSV ``t,emg1..emgN[,force,intent,intent_force_n]`` plus a JSON sidecar.

        The CSV has one header line and one row per sample (``t`` in seconds,
        sEMG in ``emg_unit``, forces in newtons), so ``pandas.read_csv``,
        ``numpy.loadtxt(f, delimiter=",", skiprows=1)`` and spreadsheets read
        it. The sampling rate, sEMG unit, channel names and metadata go to
        ``FILE.csv.json`` (see :func:`sidecar_path`), which :func:`load_recording`
        reads back.
        """
        path = Path(path)
        header = ["t"] + [f"emg{i + 1}" for i in range(self.n_channels)]
        columns = [self.t_s[:, None], self.emg.astype(float)]
        formats = ["%.6f"] + (["%d"] if self.emg.dtype.kind in "iu" else ["%.6g"]) * self.n_channels
        units = {"t": "s", **{name: self.emg_unit for name in header[1:]}}
        if self.force_n is not None:
            header.append("force")
            columns.append(self.force_n[:, None])
            formats.append("%.6g")
            units["force"] = "N"
        for name in _OPTIONAL_COLUMNS:
            value = getattr(self, name)
            if value is not None:
                header.append(name)
                columns.append(value[:, None])
                formats.append("%.6g")
                units[name] = "1 (0..1 of MVC)" if name == "intent" else "N"
        np.savetxt(path, np.hstack(columns), fmt=formats, delimiter=",",
                   header=",".join(header), comments="")
        meta = {
            "format": "griploop recording CSV sidecar",
            "version": 1,
            "csv": path.name,
            "columns": header,
            "units": units,
            "fs_hz": self.fs_hz,
            "emg_unit": self.emg_unit,
            "channel_names": self.channel_names,
            "metadata": self.metadata,
        }
        sidecar_path(path).write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
        return path


def _positive_rate(value: Any, src: str, field: str) -> float:
    """``value`` as a finite sampling rate in (0, MAX_FS_HZ] Hz, else RecordingError."""
    if isinstance(value, np.ndarray) and value.size == 1 and value.dtype.kind in "iuf":
        value = value.reshape(()).item()
    elif isinstance(value, np.generic) and value.dtype.kind in "iuf":
        value = value.item()
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RecordingError(
            f"{src}: {field}: expected a positive number of hertz, "
            f"found {_describe(value)}"
        )
    rate = float(value)
    if not (np.isfinite(rate) and 0 < rate <= MAX_FS_HZ):
        raise RecordingError(
            f"{src}: {field}: expected a positive number of hertz up to {MAX_FS_HZ:g}, "
            f"found {value!r}"
        )
    return rate


def _describe(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"array of dtype {value.dtype} and shape {value.shape}"
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


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
        and, where one exists, the ``griploop evaluate`` option that fixes it.
    """
    path = Path(path)
    columns = ColumnMap() if columns is None else columns
    if not isinstance(columns, ColumnMap):
        raise RecordingError(f"{path}: columns: expected a ColumnMap, found {_describe(columns)}")
    _check_options(str(path), time_unit, emg_unit, duplicates)
    if not path.exists():
        raise RecordingError(f"{path}: no such file")
    if not path.is_file():
        raise RecordingError(f"{path}: not a regular file (expected a .npz or .csv recording)")
    if path.suffix not in (".npz", ".csv"):
        raise RecordingError(
            f"{path}: unknown recording format {path.suffix!r}; expected .npz or .csv"
        )
    if path.suffix == ".npz":
        given = [name for name, value, default in (
            ("--time-column/--emg-columns/--force-column", columns, ColumnMap()),
            ("--time-unit", time_unit, "s"), ("--fs-hz", fs_hz, None),
            ("--resample", resample_hz, None), ("--emg-unit", emg_unit, None),
            ("--duplicates", duplicates, "average")) if value != default]
        if given:
            raise RecordingError(
                f"{path}: {given[0]} applies to CSV files only (an NPZ recording carries "
                "its own layout and rate)"
            )
    if duplicates != "average" and resample_hz is None:
        raise RecordingError(
            f"{path}: --duplicates {duplicates} applies with --resample HZ only "
            "(found no --resample); pass both"
        )
    if fs_hz is not None:
        fs_hz = _positive_rate(fs_hz, str(path), "--fs-hz")
    if resample_hz is not None:
        resample_hz = _positive_rate(resample_hz, str(path), "--resample")
    try:
        if path.suffix == ".npz":
            return _load_npz(path, max_bytes)
        return _load_csv(path, emg_unit, max_bytes, columns, time_unit, fs_hz, resample_hz,
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
    fs_hz = _positive_rate(arrays["fs_hz"], str(path), "fs_hz")
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
        raise RecordingError(f"{path}: {field}: expected one string, found {_describe(value)}")
    return str(value.reshape(()))


def _npz_names(value: np.ndarray, path: Path) -> list[str]:
    if value.dtype.kind != "U" or value.ndim != 1:
        raise RecordingError(
            f"{path}: channel_names: expected a 1-D array of strings, found {_describe(value)}"
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


def _read_text(path: Path, max_bytes: int, what: str = "file") -> str:
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


def _json_object(text: str, src: str, field: str) -> dict[str, Any]:
    try:
        meta = json.loads(text)
    except (json.JSONDecodeError, RecursionError):
        raise RecordingError(f"{src}: corrupt {field} (not valid JSON)") from None
    if not isinstance(meta, dict):
        raise RecordingError(
            f"{src}: {field}: expected a JSON object, found {type(meta).__name__}"
        )
    return meta


def _read_sidecar(path: Path, max_bytes: int) -> dict[str, Any]:
    """The JSON sidecar ``FILE.csv.json`` of a CSV recording, or ``{}`` when there is none."""
    side = sidecar_path(path)
    if not side.is_file():
        return {}
    text = _read_text(side, min(max_bytes, MAX_SIDECAR_BYTES), "sidecar")
    return _json_object(text, str(side), "griploop metadata")


def _suggest(names: list[str], pattern: str) -> str | None:
    """The first column whose lower-cased name matches ``pattern``, if any."""
    rx = re.compile(pattern)
    return next((n for n in names if rx.search(n.lower())), None)


def _shown(header: list[str]) -> str:
    text = ", ".join(repr(h[:20]) for h in header[:12])
    return text + (", ..." if len(header) > 12 else "")


def _emg_spec_columns(spec: Any, header: list[str], path: Path) -> list[int]:
    """Header positions of the sEMG columns named by ``spec`` (names, glob or range)."""
    where: dict[str, int] = {}
    for j, name in enumerate(header):
        where.setdefault(name, j)
    if isinstance(spec, str):
        text = spec.strip()
        if "," in text:
            names = [s.strip() for s in text.split(",") if s.strip()]
        elif any(ch in text for ch in "*?["):
            found = [j for j, name in enumerate(header) if fnmatch.fnmatchcase(name, text)]
            if not found:
                raise RecordingError(
                    f"{path}: --emg-columns {text!r} matches no column (columns: "
                    f"{_shown(header)})"
                )
            return found
        elif ".." in text:
            m = _EMG_RANGE.match(text)
            if not m or (m.group(3) and m.group(3) != m.group(1)):
                raise RecordingError(
                    f"{path}: --emg-columns {text!r}: expected a range like 'emg_0..emg_7' "
                    "or 'emg_0..7'"
                )
            lo, hi = int(m.group(2)), int(m.group(4))
            if hi < lo or hi - lo >= MAX_CSV_COLUMNS:
                raise RecordingError(
                    f"{path}: --emg-columns {text!r}: expected first <= last and at most "
                    f"{MAX_CSV_COLUMNS} channels"
                )
            width = len(m.group(2)) if m.group(2).startswith("0") and len(m.group(2)) > 1 else 0
            names = [f"{m.group(1)}{k:0{width}d}" for k in range(lo, hi + 1)]
        else:
            names = [text] if text else []
    elif isinstance(spec, (list, tuple)) and all(isinstance(s, str) for s in spec):
        names = list(spec)
    else:
        raise RecordingError(
            f"{path}: emg columns: expected names, a glob or a range, found {_describe(spec)}"
        )
    if not names:
        raise RecordingError(f"{path}: --emg-columns names no column")
    missing = [n for n in names if n not in where]
    if missing:
        raise RecordingError(
            f"{path}: sEMG column {missing[0][:40]!r} (from --emg-columns) not in the header "
            f"(columns: {_shown(header)})"
        )
    if len(set(names)) != len(names):
        raise RecordingError(f"{path}: --emg-columns names a column twice")
    repeated = [n for n in names if header.count(n) > 1]
    if repeated:
        raise RecordingError(
            f"{path}: sEMG column {repeated[0][:40]!r} (from --emg-columns) appears "
            f"{header.count(repeated[0])} times in the header; rename the columns or "
            "use a glob to take them all"
        )
    return [where[n] for n in names]


def _resolve_columns(
    header: list[str], columns: ColumnMap, path: Path, fs_hz: float | None
) -> tuple[int | None, list[int], int | None, dict[str, int]]:
    """Positions of the time, sEMG, force and ground-truth columns in ``header``."""
    counts: dict[str, int] = {}
    for name in header:
        counts[name] = counts.get(name, 0) + 1

    def unique(name: str, option: str) -> int:
        if counts[name] > 1:
            raise RecordingError(
                f"{path}: column {name[:40]!r} appears {counts[name]} times; "
                f"rename it or choose another with {option}"
            )
        return header.index(name)

    # time
    t_idx: int | None = None
    if columns.time is not None:
        if columns.time in counts:
            t_idx = unique(columns.time, "--time-column")
        elif fs_hz is None or columns.time != "t":
            guess = _suggest(header, r"^(time|timestamp|t_|.*_t$|.*time)")
            hint = (f"pass --time-column {guess[:40]}" if guess else "pass --time-column NAME")
            raise RecordingError(
                f"{path}: no time column {columns.time[:40]!r} (columns: {_shown(header)}); "
                f"{hint}, or --time-column none --fs-hz HZ if the file has no time column"
            )
    elif fs_hz is None:
        raise RecordingError(f"{path}: no time column and no sampling rate; pass --fs-hz HZ")
    # sEMG
    if columns.emg is None:
        emg_cols: list[tuple[int, int]] = []
        for j, name in enumerate(header):
            m = _EMG_COLUMN.match(name)
            if m:
                emg_cols.append((int(m.group(1)), j))
        if not emg_cols:
            guess = _suggest(header, r"emg|ch(an(nel)?)?[ _]?\d")
            hint = ""
            if guess:
                stem = re.sub(r"\d+$", "", guess)
                hint = f" (e.g. --emg-columns '{stem}*')" if stem else ""
            raise RecordingError(
                f"{path}: no sEMG columns emg1..emgN (columns: {_shown(header)}); "
                f"pass --emg-columns NAMES, a glob or a range{hint}"
            )
        numbers = sorted(k for k, _ in emg_cols)
        if numbers != list(range(1, len(numbers) + 1)):
            raise RecordingError(
                f"{path}: sEMG columns must be emg1..emg{len(numbers)} without gaps or repeats, "
                f"found {[f'emg{k}' for k in numbers][:10]}; or pass --emg-columns"
            )
        emg_idx = [j for _, j in sorted(emg_cols)]
    else:
        emg_idx = _emg_spec_columns(columns.emg, header, path)
    if t_idx is not None and t_idx in emg_idx:
        raise RecordingError(f"{path}: column {header[t_idx]!r} is both time and sEMG")
    # force
    f_idx: int | None = None
    if columns.force is not None:
        if columns.force in counts:
            f_idx = unique(columns.force, "--force-column")
        elif columns.force == "force":
            guess = _suggest([h for j, h in enumerate(header) if j not in emg_idx], r"force|fsr")
            if guess is not None:
                raise RecordingError(
                    f"{path}: no column 'force' but found {guess[:40]!r}: pass --force-column "
                    f"{guess[:40]} (or --force-column none to load without force)"
                )
        else:
            raise RecordingError(
                f"{path}: no force column {columns.force[:40]!r} (from --force-column; columns: "
                f"{_shown(header)})"
            )
        if f_idx is not None and (f_idx in emg_idx or f_idx == t_idx):
            raise RecordingError(f"{path}: column {columns.force!r} is used twice")
    # simulated ground truth, by griploop's names, when otherwise unused
    used = set(emg_idx) | {t_idx, f_idx}
    extra: dict[str, int] = {}
    for name in _OPTIONAL_COLUMNS:
        if name in counts and header.index(name) not in used:
            extra[name] = unique(name, "a column map")
    return t_idx, emg_idx, f_idx, extra


def _time_checks(t: np.ndarray, name: str, path: Path, time_unit: str,
                 resample: bool) -> float:
    """Check the time column (seconds); return the median positive step in seconds."""
    dt = np.diff(t)
    if np.any(dt < 0):
        row = int(np.argmax(dt < 0)) + 2
        raise RecordingError(
            f"{path}: column {name!r} is not strictly increasing at data row {row} (goes back "
            f"from {t[row - 2]:.6g} to {t[row - 1]:.6g} s after the first stamp); sort or "
            "split the file"
        )
    positive = dt[dt > 0]
    if positive.size == 0:
        raise RecordingError(f"{path}: column {name!r} holds one time stamp for every row")
    step = float(np.median(positive))
    rate = 1.0 / step
    if rate < MIN_FS_HZ or rate > MAX_FS_HZ:
        scale = _TIME_UNITS[time_unit]
        raw = step / scale
        better = [u for u, s in _TIME_UNITS.items()
                  if u != time_unit and MIN_FS_HZ <= 1.0 / (raw * s) <= MAX_FS_HZ]
        hint = f"pass --time-unit {better[0]}" if better else "pass --fs-hz HZ"
        raise RecordingError(
            f"{path}: time column {name!r} in {better[0] if better else 'other units'}? "
            f"found steps of {raw:.6g} {time_unit} ({rate:.6g} Hz, expected "
            f"{MIN_FS_HZ:g}..{MAX_FS_HZ:g} Hz): {hint}"
        )
    if resample:
        return step
    n_dup = int(np.count_nonzero(dt == 0))
    if n_dup:
        row = int(np.argmax(dt == 0)) + 2
        raise RecordingError(
            f"{path}: time stamps in column {name!r} not strictly increasing ({n_dup} "
            f"duplicates, first at data row {row}): pass --resample HZ"
        )
    irregular = np.abs(dt - step) > _TIME_RTOL * step + 2e-6
    if np.any(irregular):
        row = int(np.argmax(irregular)) + 2
        raise RecordingError(
            f"{path}: column {name!r} is irregular at data row {row} (step {dt[row - 2]:.6g} s, "
            f"expected {step:.6g} s): pass --resample HZ"
        )
    return step


def _resample(t: np.ndarray, data: np.ndarray, step: float, resample_hz: float,
              duplicates: str, path: Path, name: str, max_bytes: int) -> np.ndarray:
    """``data`` (rows at times ``t``) linearly interpolated onto a uniform grid from ``t[0]``."""
    gaps = np.diff(t) > MAX_GAP_STEPS * step
    if np.any(gaps):
        row = int(np.argmax(gaps)) + 2
        raise RecordingError(
            f"{path}: column {name!r} jumps by {t[row - 1] - t[row - 2]:.6g} s at data row "
            f"{row} ({MAX_GAP_STEPS}x its median step {step:.6g} s); resampling would invent "
            "the missing data: split the file there"
        )
    uniq, start, count = np.unique(t, return_index=True, return_counts=True)
    if duplicates == "spread":
        # k rows sharing a stamp are spread evenly up to the next stamp (MYO packets)
        nxt = np.append(uniq[1:], uniq[-1] + step)
        within = np.arange(t.size) - np.repeat(start, count)
        t = t + within * np.repeat((nxt - uniq) / count, count)
        t_u, values = t, data
    else:  # average
        sums = np.add.reduceat(data, start, axis=0)
        t_u, values = uniq, sums / count[:, None]
    if t_u.size < 2:
        raise RecordingError(f"{path}: needs at least 2 distinct time stamps to resample")
    span = float(t_u[-1] - t_u[0]) * resample_hz
    n_out = int(np.floor(span + 1e-9)) + 1 if np.isfinite(span) and span < 2**53 else 2**53
    if n_out < 2 or n_out * data.shape[1] * 8 > max_bytes:
        raise RecordingError(
            f"{path}: --resample {resample_hz:g} over {t_u[-1] - t_u[0]:.6g} s gives {n_out} "
            f"samples (expected 2..{max(2, max_bytes // (8 * data.shape[1]))}); choose another HZ"
        )
    grid = t_u[0] + np.arange(n_out) / resample_hz
    out = np.empty((n_out, data.shape[1]))
    for j in range(data.shape[1]):
        out[:, j] = np.interp(grid, t_u, values[:, j])
    return out


def _data_rows(lines: list[str]) -> list[str]:
    return [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]


def _load_csv(path: Path, emg_unit: str | None, max_bytes: int, columns: ColumnMap,
              time_unit: str, fs_hz: float | None, resample_hz: float | None,
              duplicates: str) -> Recording:
    lines = _read_text(path, max_bytes).splitlines()
    header, meta, n_comment = _csv_header(path, lines, max_bytes)
    t_idx, emg_idx, f_idx, extra = _resolve_columns(header, columns, path, fs_hz)
    used = ([t_idx] if t_idx is not None else []) + emg_idx
    used += ([f_idx] if f_idx is not None else []) + list(extra.values())
    data = _csv_data(path, lines[n_comment:], header, used)
    pos = {j: k for k, j in enumerate(used)}
    emg = data[:, [pos[j] for j in emg_idx]]
    unit = _csv_emg_unit(path, emg, emg_unit if emg_unit is not None else meta.get("emg_unit"))
    metadata = meta.get("metadata", {})
    ignored = [header[j] for j in range(len(header)) if j not in pos]
    if isinstance(metadata, dict) and (ignored or not columns.is_default):
        metadata = dict(metadata)
        metadata["csv_layout"] = {
            "time": None if t_idx is None else header[t_idx],
            "time_unit": time_unit,
            "emg": [header[j] for j in emg_idx],
            "force": None if f_idx is None else header[f_idx],
            "ignored": ignored,
        }
    if t_idx is None:
        rate = _positive_rate(fs_hz, str(path), "--fs-hz")
        if resample_hz is not None:
            raise RecordingError(f"{path}: --resample needs a time column (found none)")
    elif resample_hz is not None:
        rate, data, resampled = _csv_resampled(path, data[:, pos[t_idx]], data, header[t_idx],
                                               time_unit, resample_hz, duplicates, max_bytes)
        emg = data[:, [pos[j] for j in emg_idx]]
        if unit == "int8":
            emg = np.clip(np.round(emg), -128, 127)
        if isinstance(metadata, dict):
            metadata = dict(metadata)
            metadata["resampled"] = resampled
    else:
        rate = _csv_time_rate(path, data[:, pos[t_idx]], header[t_idx], time_unit,
                              [("metadata fs_hz", meta.get("fs_hz")), ("--fs-hz", fs_hz)])
    if unit == "int8":
        emg = emg.astype(np.int8)
    names = _csv_channel_names(path, meta, [header[j] for j in emg_idx]
                               if columns.emg is not None else None)

    def col(j: int | None) -> np.ndarray | None:
        return None if j is None else data[:, pos[j]]

    return Recording(
        emg=emg,
        fs_hz=rate,
        force_n=col(f_idx),
        channel_names=names,
        emg_unit=unit,
        intent=col(extra.get("intent")),
        intent_force_n=col(extra.get("intent_force_n")),
        metadata=metadata,
        source=str(path),
    )


def _csv_header(path: Path, lines: list[str], max_bytes: int
                ) -> tuple[list[str], dict[str, Any], int]:
    """The CSV's header, its metadata and how many lines precede the data.

    The metadata is the file's own ``# griploop {...}`` line, else its sidecar
    JSON (:func:`sidecar_path`), else empty.

    Returns
    -------
    header : list of str
        Column names, stripped.
    meta : dict
        The griploop metadata (``fs_hz``, ``emg_unit``, ``channel_names``, ``metadata``).
    n_before_data : int
        Lines up to and including the header.
    """
    import csv

    meta: dict[str, Any] = {}
    header: list[str] | None = None
    n_comment = 0
    in_file_meta = False
    for line in lines:
        n_comment += 1
        stripped = line.strip()
        if stripped.startswith("#"):
            body = stripped.lstrip("#").strip()
            if body.startswith("griploop "):
                meta = _json_object(body[len("griploop "):], str(path), "griploop metadata line")
                in_file_meta = True
            continue
        if not stripped:
            continue
        try:
            header = [h.strip() for h in next(csv.reader([stripped]))]
        except (csv.Error, StopIteration):
            header = [h.strip() for h in stripped.split(",")]
        break
    if not header or header == [""]:
        raise RecordingError(f"{path}: no header line; expected 't,emg1,...,emgN[,force]'")
    if len(header) > MAX_CSV_COLUMNS:
        raise RecordingError(
            f"{path}: {len(header)} columns (expected at most {MAX_CSV_COLUMNS}: "
            "t, emg1..emg256, force, intent, intent_force_n)"
        )
    if not in_file_meta:
        meta = _read_sidecar(path, max_bytes)
    if len(header) == 1 and ";" in header[0]:
        raise RecordingError(
            f"{path}: one column {header[0][:40]!r}: the file looks ';'-separated; "
            "expected ',' as the delimiter"
        )
    return header, meta, n_comment


def _csv_data(path: Path, lines: list[str], header: list[str], used: list[int]) -> np.ndarray:
    """The CSV's data rows parsed as numbers, columns ``used`` only.

    Returns
    -------
    ndarray, shape (n_rows, len(used))
        Finite floats.

    Raises
    ------
    RecordingError
        Fewer than 2 rows, rows wider or narrower than the header, text that
        is not a number, or NaN/inf in a used column.
    """
    import io

    rows = _data_rows(lines)
    if len(rows) < 2:
        raise RecordingError(f"{path}: needs at least 2 rows to define the sampling rate")
    body = "\n".join(rows)
    if '"' not in body:
        widths = np.fromiter((r.count(",") + 1 for r in rows), dtype=np.int64, count=len(rows))
        bad = np.flatnonzero(widths != len(header))
        if bad.size:
            raise RecordingError(
                f"{path}: data row {int(bad[0]) + 1}: {int(widths[bad[0]])} values per row but "
                f"{len(header)} header columns"
            )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, dtype=float,
                              usecols=used, quotechar='"')
    except ValueError as exc:
        reason = " ".join(str(exc).split())[:160]
        raise RecordingError(f"{path}: unparsable numeric data ({reason})") from None
    if data.shape[1] != len(used):
        raise RecordingError(
            f"{path}: {data.shape[1]} values per row but {len(used)} columns used"
        )
    for k, j in enumerate(used):
        col = data[:, k]
        if not np.all(np.isfinite(col)):
            row = int(np.argwhere(~np.isfinite(col))[0][0]) + 1
            raise RecordingError(
                f"{path}: column {header[j][:40]!r} has NaN or inf at data row {row}; "
                "expected finite numbers"
            )
    return data


def _csv_emg_unit(path: Path, emg: np.ndarray, unit: Any) -> str:
    """The sEMG unit: the one given, else ``int8`` for integers in -128..127, else ``uV``.

    Raises
    ------
    RecordingError
        An unknown unit, or ``int8`` for values that are not such integers.
    """
    if unit is None:
        integral = np.all(emg == np.round(emg))
        unit = "int8" if integral and emg.min() >= -128 and emg.max() <= 127 else "uV"
    if not isinstance(unit, str) or unit not in EMG_UNITS:
        raise RecordingError(f"{path}: emg_unit must be one of {EMG_UNITS}, found {unit!r}")
    if unit == "int8" and (
        emg.min() < -128 or emg.max() > 127 or not np.array_equal(emg, np.round(emg))
    ):
        raise RecordingError(
            f"{path}: emg_unit int8 but values are not integers in -128..127 "
            f"(found {emg.min():.6g}..{emg.max():.6g}): pass --emg-unit uV (or mV, a.u.)"
        )
    return unit


def _csv_times_s(path: Path, raw_t: np.ndarray, tname: str, time_unit: str) -> np.ndarray:
    """The time column in seconds from its first stamp, shape (n_rows,)."""
    # relative to the first stamp before scaling: exact for integer epoch stamps
    with np.errstate(over="ignore", invalid="ignore"):
        t = (raw_t - raw_t[0]) * _TIME_UNITS[time_unit]
    if not np.all(np.isfinite(t)):
        raise RecordingError(f"{path}: column {tname!r} spans more than a float can hold")
    return t


def _csv_resampled(path: Path, raw_t: np.ndarray, data: np.ndarray, tname: str,
                   time_unit: str, resample_hz: float, duplicates: str, max_bytes: int
                   ) -> tuple[float, np.ndarray, dict[str, Any]]:
    """Resample every used column onto a regular grid at ``resample_hz``.

    Returns
    -------
    rate : float
        ``resample_hz``, Hz.
    data : ndarray, shape (n_resampled, n_used)
    resampled : dict
        What was done, for the recording's metadata.
    """
    t = _csv_times_s(path, raw_t, tname, time_unit)
    step = _time_checks(t, tname, path, time_unit, True)
    rate = _positive_rate(resample_hz, str(path), "--resample")
    n_in = data.shape[0]
    data = _resample(t, data, step, rate, duplicates, path, tname, max_bytes)
    return rate, data, {"fs_hz": rate, "from_rows": n_in, "median_step_s": step,
                        "duplicates": duplicates, "method": "linear (numpy.interp)"}


def _csv_time_rate(path: Path, raw_t: np.ndarray, tname: str, time_unit: str,
                   claims: list[tuple[str, Any]]) -> float:
    """The sampling rate of a regular time column, Hz, checked against stated rates.

    The mean step is used (regularity is checked first); the median of stamps
    rounded to a few decimals is biased (2048 Hz written as %.6f gave
    2049.18 Hz). A stated rate (``claims``: label and value, None if not
    stated) that agrees with the column within :data:`_RATE_RTOL` is the exact
    one; one that does not is an error.
    """
    t = _csv_times_s(path, raw_t, tname, time_unit)
    _time_checks(t, tname, path, time_unit, False)
    step = float(t[-1] - t[0]) / (t.size - 1)
    time_rate = _positive_rate(1.0 / step, str(path), f"column {tname!r} (1 / step)")
    rate = time_rate
    for label, value in claims:
        if value is None:
            continue
        claimed = _positive_rate(value, str(path), label)
        if abs(claimed - time_rate) > _RATE_RTOL * time_rate:
            raise RecordingError(
                f"{path}: {label} {claimed:g} Hz contradicts column {tname!r} "
                f"({time_rate:.6g} Hz from its {step:.6g} s step); expected them to "
                f"agree within {_RATE_RTOL:.0%}"
            )
        rate = claimed
    return rate


def _csv_channel_names(path: Path, meta: dict[str, Any],
                       emg_columns: list[str] | None) -> list[str] | None:
    """Channel names: the chosen sEMG columns' headers, else the metadata's ``channel_names``."""
    if emg_columns is not None:
        return emg_columns
    names = meta.get("channel_names")
    if names is not None and (
        not isinstance(names, list) or not all(isinstance(x, str) for x in names)
    ):
        raise RecordingError(
            f"{path}: metadata channel_names: expected a list of strings, found {_describe(names)}"
        )
    return names
