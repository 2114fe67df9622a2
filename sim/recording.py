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
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

EMG_UNITS = ("int8", "uV", "mV", "a.u.")
_OPTIONAL_COLUMNS = ("intent", "intent_force_n")
_EMG_COLUMN = re.compile(r"^emg(\d+)$")
# Relative tolerance on sample-interval regularity of the time column.
_TIME_RTOL = 1e-3


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
        if not (np.isfinite(self.fs_hz) and self.fs_hz > 0):
            raise RecordingError(f"{src}: fs_hz must be a positive number, found {self.fs_hz!r}")
        if emg.dtype.kind == "f" and not np.all(np.isfinite(emg)):
            bad = int(np.argwhere(~np.isfinite(emg))[0][1])
            raise RecordingError(
                f"{src}: column emg{bad + 1} contains NaN or inf; expected finite values"
            )
        if emg.dtype.kind not in "iuf":
            raise RecordingError(f"{src}: emg must be numeric, found dtype {emg.dtype}")
        if self.emg_unit not in EMG_UNITS:
            raise RecordingError(
                f"{src}: emg_unit must be one of {EMG_UNITS}, found {self.emg_unit!r}"
            )
        self.emg = emg
        self.fs_hz = float(self.fs_hz)
        if self.channel_names is None:
            self.channel_names = [f"emg{i + 1}" for i in range(c)]
        else:
            self.channel_names = [str(name) for name in self.channel_names]
            if len(self.channel_names) != c:
                raise RecordingError(
                    f"{src}: {len(self.channel_names)} channel names for {c} channels"
                )
        for name in ("force_n", "intent", "intent_force_n"):
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.asarray(value, dtype=float)
            if arr.shape != (n,):
                raise RecordingError(
                    f"{src}: {name} must have shape ({n},) to match emg, found {arr.shape}"
                )
            if not np.all(np.isfinite(arr)):
                raise RecordingError(f"{src}: column {name} contains NaN or inf")
            setattr(self, name, arr)

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


def load_recording(path: str | Path, *, emg_unit: str | None = None) -> Recording:
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

    Raises
    ------
    RecordingError
        Missing file, unknown format, NaN/inf, missing or extra columns,
        non-monotonic or irregular time.
    """
    path = Path(path)
    if not path.exists():
        raise RecordingError(f"{path}: no such file")
    if path.suffix == ".npz":
        return _load_npz(path)
    if path.suffix == ".csv":
        return _load_csv(path, emg_unit)
    raise RecordingError(f"{path}: unknown recording format {path.suffix!r}; expected .npz or .csv")


def _load_npz(path: Path) -> Recording:
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except Exception as exc:  # zipfile/pickle errors: the file is not an NPZ
        raise RecordingError(f"{path}: not a readable NPZ file ({exc})") from exc
    for key in ("emg", "fs_hz"):
        if key not in arrays:
            raise RecordingError(f"{path}: missing array {key!r}")
    known = {"emg", "fs_hz", "channel_names", "emg_unit", "metadata_json", "force_n", "intent",
             "intent_force_n"}
    extra = sorted(set(arrays) - known)
    if extra:
        raise RecordingError(
            f"{path}: unknown arrays {extra}; expected a subset of {sorted(known)}"
        )
    return Recording(
        emg=arrays["emg"],
        fs_hz=float(arrays["fs_hz"]),
        force_n=arrays.get("force_n"),
        channel_names=[str(s) for s in arrays["channel_names"]]
        if "channel_names" in arrays else None,
        emg_unit=str(arrays["emg_unit"]) if "emg_unit" in arrays else "int8",
        intent=arrays.get("intent"),
        intent_force_n=arrays.get("intent_force_n"),
        metadata=json.loads(str(arrays["metadata_json"])) if "metadata_json" in arrays else {},
        source=str(path),
    )


def _load_csv(path: Path, emg_unit: str | None) -> Recording:
    meta: dict[str, Any] = {}
    header: list[str] | None = None
    n_comment = 0
    with path.open() as fh:
        for line in fh:
            n_comment += 1
            stripped = line.strip()
            if stripped.startswith("#"):
                body = stripped.lstrip("#").strip()
                if body.startswith("griploop "):
                    try:
                        meta = json.loads(body[len("griploop "):])
                    except json.JSONDecodeError as exc:
                        raise RecordingError(f"{path}: corrupt griploop metadata line") from exc
                continue
            header = [h.strip() for h in stripped.split(",")]
            break
    if not header or header == [""]:
        raise RecordingError(f"{path}: no header line; expected 't,emg1,...,emgN[,force]'")
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
                f"{path}: unknown column {name!r}; expected t, emg1..emgN, force, "
                f"{', '.join(_OPTIONAL_COLUMNS)}"
            )
    if not emg_cols:
        raise RecordingError(f"{path}: no sEMG columns; expected emg1, emg2, ...")
    numbers = sorted(k for k, _ in emg_cols)
    if numbers != list(range(1, len(numbers) + 1)):
        raise RecordingError(
            f"{path}: sEMG columns must be emg1..emg{len(numbers)} without gaps or repeats, "
            f"found {[f'emg{k}' for k in numbers]}"
        )
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=n_comment, ndmin=2)
    except ValueError as exc:
        raise RecordingError(f"{path}: unparsable numeric data ({exc})") from exc
    if data.shape[1] != len(header):
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
    fs_hz = float(meta.get("fs_hz", 1.0 / dt_med))
    order = [j for _, j in sorted(emg_cols)]
    emg = data[:, order]
    unit = meta.get("emg_unit", emg_unit)
    if unit is None:
        integral = np.all(emg == np.round(emg))
        unit = "int8" if integral and emg.min() >= -128 and emg.max() <= 127 else "uV"
    emg = emg.astype(np.int8) if unit == "int8" else emg
    if unit == "int8" and not np.array_equal(emg, data[:, order]):
        raise RecordingError(f"{path}: emg_unit int8 but values are not integers in -128..127")

    def col(name: str) -> np.ndarray | None:
        return data[:, other[name]] if name in other else None

    return Recording(
        emg=emg,
        fs_hz=fs_hz,
        force_n=col("force"),
        channel_names=meta.get("channel_names"),
        emg_unit=unit,
        intent=col("intent"),
        intent_force_n=col("intent_force_n"),
        metadata=meta.get("metadata", {}),
        source=str(path),
    )
