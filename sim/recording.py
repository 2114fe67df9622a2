"""One sEMG + force recording, simulated or real, and its NPZ/CSV file formats.

A :class:`Recording` is what a MYO armband and an FSR produce in one session:
multichannel sEMG of shape ``(n_samples, n_channels)`` sampled at ``fs_hz``, the
measured grip force in newtons (optional), and, for simulated subjects, the
ground-truth intent (normalized force, 0..1) that produced them.

CSV layout (one row per sample)::

    t,emg1,emg2,...,emg8,force
    0.000,3,-1,...,0,0.512

``t`` is in seconds and must be strictly increasing at a regular interval;
channel columns are named ``emg1..emgN`` (1-based, as on the MYO); ``force`` is
in newtons. Optional extra columns ``intent`` and ``intent_force_n`` carry the
simulated ground truth. Any other column is rejected, never silently dropped.
"""

from __future__ import annotations

import json
import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

EMG_UNITS = ("int8", "uV", "mV", "a.u.")
_OPTIONAL_COLUMNS = ("intent", "intent_force_n")
_EMG_COLUMN = re.compile(r"^emg(\d+)$")
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


class RecordingError(ValueError):
    """A recording file or array is malformed.

    The message names the source (file or argument), the column or field and
    what was expected versus what was found.
    """


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
        """Save as CSV: ``t,emg1..emgN,force[,intent,intent_force_n]``.

        Metadata, the sEMG unit and channel names go into ``#`` comment lines
        at the top so that a round trip keeps them.
        """
        path = Path(path)
        header = ["t"] + [f"emg{i + 1}" for i in range(self.n_channels)]
        columns = [self.t_s[:, None], self.emg.astype(float)]
        formats = ["%.6f"] + (["%d"] if self.emg.dtype.kind in "iu" else ["%.6g"]) * self.n_channels
        if self.force_n is not None:
            header.append("force")
            columns.append(self.force_n[:, None])
            formats.append("%.6g")
        for name in _OPTIONAL_COLUMNS:
            value = getattr(self, name)
            if value is not None:
                header.append(name)
                columns.append(value[:, None])
                formats.append("%.6g")
        meta = {
            "fs_hz": self.fs_hz,
            "emg_unit": self.emg_unit,
            "channel_names": self.channel_names,
            "metadata": self.metadata,
        }
        comment = "griploop " + json.dumps(meta, sort_keys=True)
        np.savetxt(
            path,
            np.hstack(columns),
            fmt=formats,
            delimiter=",",
            header=comment + "\n" + ",".join(header),
            comments="# ",
        )
        # np.savetxt prefixes every header line with the comment marker; the
        # column header must be a plain line, so rewrite the second line.
        lines = path.read_text().splitlines(keepends=True)
        lines[1] = lines[1][2:]
        path.write_text("".join(lines))
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
    path: str | Path, *, emg_unit: str | None = None, max_bytes: int = MAX_FILE_BYTES
) -> Recording:
    """Load a recording from ``.npz`` or ``.csv``.

    Parameters
    ----------
    path : str or Path
        The file. CSV files written by other tools need only the header
        ``t,emg1..emgN[,force]``; the sampling rate is derived from ``t``.
    emg_unit : str, optional
        Unit of the sEMG columns for CSV files without griploop metadata.
        Default: ``"int8"`` when every value is an integer within -128..127,
        otherwise ``"uV"``.
    max_bytes : int
        Largest CSV file, or largest total of an NPZ file's arrays
        uncompressed (as their zip headers declare, checked before anything
        is decompressed), bytes.

    Raises
    ------
    RecordingError
        The only exception: missing or unreadable file, unknown format,
        oversized file or array, NaN/inf, values outside the unit's range,
        missing or extra columns, non-monotonic or irregular time, a metadata
        sampling rate contradicting the time column. The message names the
        file and the field.
    """
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: no such file")
    if not path.is_file():
        raise RecordingError(f"{path}: not a regular file (expected a .npz or .csv recording)")
    if path.suffix not in (".npz", ".csv"):
        raise RecordingError(
            f"{path}: unknown recording format {path.suffix!r}; expected .npz or .csv"
        )
    try:
        if path.suffix == ".npz":
            return _load_npz(path, max_bytes)
        return _load_csv(path, emg_unit, max_bytes)
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


def _load_csv(path: Path, emg_unit: str | None, max_bytes: int) -> Recording:
    import io

    size = path.stat().st_size
    if size > max_bytes:
        raise RecordingError(
            f"{path}: file of {size} bytes (expected at most {max_bytes}); "
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
        raise RecordingError(f"{path}: contains NUL bytes (expected CSV text)")
    meta: dict[str, Any] = {}
    header: list[str] | None = None
    lines = text.splitlines()
    n_comment = 0
    for line in lines:
        n_comment += 1
        stripped = line.strip()
        if stripped.startswith("#"):
            body = stripped.lstrip("#").strip()
            if body.startswith("griploop "):
                try:
                    meta = json.loads(body[len("griploop "):])
                except (json.JSONDecodeError, RecursionError):
                    raise RecordingError(f"{path}: corrupt griploop metadata line") from None
                if not isinstance(meta, dict):
                    raise RecordingError(
                        f"{path}: griploop metadata: expected a JSON object, "
                        f"found {type(meta).__name__}"
                    )
            continue
        header = [h.strip() for h in stripped.split(",")]
        break
    if not header or header == [""]:
        raise RecordingError(f"{path}: no header line; expected 't,emg1,...,emgN[,force]'")
    if len(header) > MAX_CSV_COLUMNS:
        raise RecordingError(
            f"{path}: {len(header)} columns (expected at most {MAX_CSV_COLUMNS}: "
            "t, emg1..emg256, force, intent, intent_force_n)"
        )
    if header[0] != "t":
        raise RecordingError(f"{path}: first column must be 't' (seconds), found {header[0]!r}")
    emg_cols: list[tuple[int, int]] = []
    other: dict[str, int] = {}
    for j, name in enumerate(header[1:], start=1):
        m = _EMG_COLUMN.match(name)
        if m:
            emg_cols.append((int(m.group(1)), j))
        elif name == "force" or name in _OPTIONAL_COLUMNS:
            if name in other:
                raise RecordingError(f"{path}: column {name!r} appears twice")
            other[name] = j
        else:
            raise RecordingError(
                f"{path}: unknown column {name[:40]!r}; expected t, emg1..emgN, force, "
                f"{', '.join(_OPTIONAL_COLUMNS)}"
            )
    if not emg_cols:
        raise RecordingError(f"{path}: no sEMG columns; expected emg1, emg2, ...")
    numbers = sorted(k for k, _ in emg_cols)
    if numbers != list(range(1, len(numbers) + 1)):
        raise RecordingError(
            f"{path}: sEMG columns must be emg1..emg{len(numbers)} without gaps or repeats, "
            f"found {[f'emg{k}' for k in numbers][:10]}"
        )
    body = "\n".join(lines[n_comment:])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
            data = np.loadtxt(io.StringIO(body), delimiter=",", ndmin=2, dtype=float)
    except ValueError as exc:
        reason = " ".join(str(exc).split())[:160]
        raise RecordingError(f"{path}: unparsable numeric data ({reason})") from None
    if data.shape[1] != len(header) and data.size:
        raise RecordingError(
            f"{path}: {data.shape[1]} values per row but {len(header)} header columns"
        )
    if data.shape[0] < 2:
        raise RecordingError(f"{path}: needs at least 2 rows to define the sampling rate")
    for j, name in enumerate(header):
        col = data[:, j]
        if not np.all(np.isfinite(col)):
            row = int(np.argwhere(~np.isfinite(col))[0][0]) + 1
            raise RecordingError(
                f"{path}: column {name!r} has NaN or inf at data row {row}; expected finite numbers"
            )
    t = data[:, 0]
    dt = np.diff(t)
    if np.any(dt <= 0):
        row = int(np.argmax(dt <= 0)) + 2
        raise RecordingError(f"{path}: column 't' is not strictly increasing at data row {row}")
    dt_med = float(np.median(dt))
    irregular = np.abs(dt - dt_med) > _TIME_RTOL * dt_med + 2e-6
    if np.any(irregular):
        row = int(np.argmax(irregular)) + 2
        raise RecordingError(
            f"{path}: column 't' is irregular at data row {row} (step {dt[row - 2]:.6g} s, "
            f"expected {dt_med:.6g} s); resample before loading"
        )
    fs_time = _positive_rate(1.0 / dt_med, str(path), "column 't' (1 / step)")
    if "fs_hz" in meta:
        fs_hz = _positive_rate(meta["fs_hz"], str(path), "metadata fs_hz")
        if abs(fs_hz - fs_time) > _RATE_RTOL * fs_time:
            raise RecordingError(
                f"{path}: metadata fs_hz {fs_hz:g} Hz contradicts column 't' "
                f"({fs_time:.6g} Hz from its {dt_med:.6g} s step); expected them to agree "
                f"within {_RATE_RTOL:.0%}"
            )
    else:
        fs_hz = fs_time
    order = [j for _, j in sorted(emg_cols)]
    emg = data[:, order]
    unit = meta.get("emg_unit", emg_unit)
    if unit is None:
        integral = np.all(emg == np.round(emg))
        unit = "int8" if integral and emg.min() >= -128 and emg.max() <= 127 else "uV"
    if not isinstance(unit, str) or unit not in EMG_UNITS:
        raise RecordingError(f"{path}: emg_unit must be one of {EMG_UNITS}, found {unit!r}")
    if unit == "int8":
        if emg.min() < -128 or emg.max() > 127 or not np.array_equal(emg, np.round(emg)):
            raise RecordingError(
                f"{path}: emg_unit int8 but values are not integers in -128..127 "
                f"(found {emg.min():.6g}..{emg.max():.6g})"
            )
        emg = emg.astype(np.int8)
    names = meta.get("channel_names")
    if names is not None and (
        not isinstance(names, list) or not all(isinstance(x, str) for x in names)
    ):
        raise RecordingError(
            f"{path}: metadata channel_names: expected a list of strings, found {_describe(names)}"
        )

    def col(name: str) -> np.ndarray | None:
        return data[:, other[name]] if name in other else None

    return Recording(
        emg=emg,
        fs_hz=fs_hz,
        force_n=col("force"),
        channel_names=names,
        emg_unit=unit,
        intent=col("intent"),
        intent_force_n=col("intent_force_n"),
        metadata=meta.get("metadata", {}),
        source=str(path),
    )
