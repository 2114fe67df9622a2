"""Reading CSV recordings: griploop's own and other tools' (pandas, MYO dumps, loggers).

A CSV needs one header line; its columns are found through a
:class:`~sim.recording.columns.ColumnMap` (griploop's ``t,emg1..emgN[,force]`` by
default) and columns the map does not use are ignored. The sampling rate comes from
the time column (in seconds, ms or us), checked for regularity and against any rate
the metadata or the caller states, or from the caller when there is no time column.
Jittered or duplicated time stamps are refused unless the caller asks to resample
them onto a uniform grid. Metadata come from the sidecar ``FILE.csv.json`` or an
old ``# griploop {json}`` first line. ``docs/FORMAT.md`` documents the formats.
"""

from __future__ import annotations

import csv
import io
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from sim.recording.checks import (
    EMG_UNITS,
    MAX_CSV_COLUMNS,
    MAX_FS_HZ,
    MAX_GAP_STEPS,
    MAX_SIDECAR_BYTES,
    MIN_FS_HZ,
    TIME_UNIT_S,
    describe,
    json_object,
    positive_rate,
    read_text,
)
from sim.recording.columns import ColumnMap, resolve_columns
from sim.recording.core import Recording
from sim.recording.errors import Fix, RecordingError
from sim.recording.writing import sidecar_path

# Relative tolerance on sample-interval regularity of the time column.
_TIME_RTOL = 1e-3
# Relative tolerance between a stated sampling rate and the time column's.
_RATE_RTOL = 1e-2


def load_csv(path: Path, emg_unit: str | None, max_bytes: int, columns: ColumnMap,
             time_unit: str, fs_hz: float | None, resample_hz: float | None,
             duplicates: str) -> Recording:
    """A CSV recording, its options checked by ``load_recording`` (see there)."""
    lines = read_text(path, max_bytes).splitlines()
    header, meta, n_comment = _csv_header(path, lines, max_bytes)
    t_idx, emg_idx, f_idx, extra = resolve_columns(header, columns, path, fs_hz)
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
        rate = positive_rate(fs_hz, str(path), "sampling rate", option="fs_hz")
        if resample_hz is not None:
            raise RecordingError(f"{path}: resampling needs a time column (found none)",
                                 option="resample_hz")
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
                              [("metadata fs_hz", meta.get("fs_hz"), None),
                               ("sampling rate", fs_hz, "fs_hz")])
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
        pitch_rad=col(extra.get("pitch_rad")),
        open_intent=col(extra.get("open_intent")),
        metadata=metadata,
        source=str(path),
    )


def _read_sidecar(path: Path, max_bytes: int) -> dict[str, Any]:
    """The JSON sidecar ``FILE.csv.json`` of a CSV recording, or ``{}`` when there is none."""
    side = sidecar_path(path)
    if not side.is_file():
        return {}
    text = read_text(side, min(max_bytes, MAX_SIDECAR_BYTES), "sidecar")
    return json_object(text, str(side), "griploop metadata")


def _csv_header(path: Path, lines: list[str], max_bytes: int
                ) -> tuple[list[str], dict[str, Any], int]:
    """The CSV's header, its metadata and how many lines precede the data.

    The metadata is the file's own ``# griploop {...}`` line, else its sidecar
    JSON (:func:`~sim.recording.writing.sidecar_path`), else empty.

    Returns
    -------
    header : list of str
        Column names, stripped.
    meta : dict
        The griploop metadata (``fs_hz``, ``emg_unit``, ``channel_names``, ``metadata``).
    n_before_data : int
        Lines up to and including the header.
    """
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
                meta = json_object(body[len("griploop "):], str(path), "griploop metadata line")
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
            "t, emg1..emg256, force, intent, intent_force_n, pitch_rad, open_intent)"
        )
    if not in_file_meta:
        meta = _read_sidecar(path, max_bytes)
    if len(header) == 1 and ";" in header[0]:
        raise RecordingError(
            f"{path}: one column {header[0][:40]!r}: the file looks ';'-separated; "
            "expected ',' as the delimiter"
        )
    return header, meta, n_comment


def _data_rows(lines: list[str]) -> list[str]:
    return [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]


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
            f"{path}: sEMG unit int8 but values are not integers in -128..127 "
            f"(found {emg.min():.6g}..{emg.max():.6g}); expected another unit",
            fixes=[Fix.set("emg_unit", other) for other in EMG_UNITS if other != "int8"])
    return unit


# ----------------------------------------------------------------- the time column
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
        raw = step / TIME_UNIT_S[time_unit]
        better = [u for u, s in TIME_UNIT_S.items()
                  if u != time_unit and MIN_FS_HZ <= 1.0 / (raw * s) <= MAX_FS_HZ]
        fix = (Fix.set("time_unit", better[0]) if better else
               Fix((("time_column", "none"), ("fs_hz", None))))
        raise RecordingError(
            f"{path}: time column {name!r} in {better[0] if better else 'other units'}? "
            f"found steps of {raw:.6g} {time_unit} ({rate:.6g} Hz, expected "
            f"{MIN_FS_HZ:g}..{MAX_FS_HZ:g} Hz)", fixes=[fix])
    if resample:
        return step
    n_dup = int(np.count_nonzero(dt == 0))
    if n_dup:
        row = int(np.argmax(dt == 0)) + 2
        raise RecordingError(
            f"{path}: time stamps in column {name!r} not strictly increasing ({n_dup} "
            f"duplicates, first at data row {row}); expected one row per stamp, or resampling",
            fixes=[Fix.set("resample_hz")])
    irregular = np.abs(dt - step) > _TIME_RTOL * step + 2e-6
    if np.any(irregular):
        row = int(np.argmax(irregular)) + 2
        raise RecordingError(
            f"{path}: column {name!r} is irregular at data row {row} (step {dt[row - 2]:.6g} s, "
            f"expected {step:.6g} s)", fixes=[Fix.set("resample_hz")])
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
            f"{path}: resampling at {resample_hz:g} Hz over {t_u[-1] - t_u[0]:.6g} s gives "
            f"{n_out} samples (expected 2..{max(2, max_bytes // (8 * data.shape[1]))}); "
            "choose another rate", option="resample_hz")
    grid = t_u[0] + np.arange(n_out) / resample_hz
    out = np.empty((n_out, data.shape[1]))
    for j in range(data.shape[1]):
        out[:, j] = np.interp(grid, t_u, values[:, j])
    return out


def _csv_times_s(path: Path, raw_t: np.ndarray, tname: str, time_unit: str) -> np.ndarray:
    """The time column in seconds from its first stamp, shape (n_rows,)."""
    # relative to the first stamp before scaling: exact for integer epoch stamps
    with np.errstate(over="ignore", invalid="ignore"):
        t = (raw_t - raw_t[0]) * TIME_UNIT_S[time_unit]
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
    rate = positive_rate(resample_hz, str(path), "resampling rate", option="resample_hz")
    n_in = data.shape[0]
    data = _resample(t, data, step, rate, duplicates, path, tname, max_bytes)
    return rate, data, {"fs_hz": rate, "from_rows": n_in, "median_step_s": step,
                        "duplicates": duplicates, "method": "linear (numpy.interp)"}


def _csv_time_rate(path: Path, raw_t: np.ndarray, tname: str, time_unit: str,
                   claims: list[tuple[str, Any, str | None]]) -> float:
    """The sampling rate of a regular time column, Hz, checked against stated rates.

    The mean step is used (regularity is checked first); the median of stamps
    rounded to a few decimals is biased (2048 Hz written as %.6f gave
    2049.18 Hz). A stated rate (``claims``: label, value or None if not stated,
    and the layout option it came from) that agrees with the column within
    :data:`_RATE_RTOL` is the exact one; one that does not is an error.
    """
    t = _csv_times_s(path, raw_t, tname, time_unit)
    _time_checks(t, tname, path, time_unit, False)
    step = float(t[-1] - t[0]) / (t.size - 1)
    time_rate = positive_rate(1.0 / step, str(path), f"column {tname!r} (1 / step)")
    rate = time_rate
    for label, value, option in claims:
        if value is None:
            continue
        claimed = positive_rate(value, str(path), label, option=option)
        if abs(claimed - time_rate) > _RATE_RTOL * time_rate:
            raise RecordingError(
                f"{path}: {label} {claimed:g} Hz contradicts column {tname!r} "
                f"({time_rate:.6g} Hz from its {step:.6g} s step); expected them to "
                f"agree within {_RATE_RTOL:.0%}", option=option)
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
            f"{path}: metadata channel_names: expected a list of strings, found {describe(names)}"
        )
    return names
