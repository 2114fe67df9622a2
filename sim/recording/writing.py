"""Writing a :class:`~sim.recording.Recording`: lossless NPZ, or plain CSV with a JSON sidecar.

CSV layout written by griploop (one header line, one row per sample)::

    t,emg1,emg2,...,emg8,force
    0.000000,3,-1,...,0,0.512

``t`` is in seconds; channel columns are named ``emg1..emgN`` (1-based, as on the
MYO); ``force`` is in newtons; optional ``intent`` and ``intent_force_n`` carry the
simulated ground truth, ``pitch_rad`` the forearm's pitch (rad). Metadata (rate, sEMG
unit, channel names, provenance) go to the JSON sidecar ``FILE.csv.json``
(:func:`sidecar_path`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from sim.recording.checks import OPTIONAL_COLUMNS
from sim.recording.errors import RecordingError


class RecordingFields(Protocol):
    """What writing reads of a :class:`sim.recording.core.Recording` (its fields, by name).

    Writing depends on these fields only, so that the recording's class can call the
    writers without the two modules importing each other.
    """

    emg: np.ndarray
    fs_hz: float
    force_n: np.ndarray | None
    channel_names: list[str]
    emg_unit: str
    intent: np.ndarray | None
    intent_force_n: np.ndarray | None
    pitch_rad: np.ndarray | None
    open_intent: np.ndarray | None
    metadata: dict[str, Any]

    @property
    def n_channels(self) -> int:
        """Number of sEMG channels."""

    @property
    def t_s(self) -> np.ndarray:
        """Sample times, s, shape (n_samples,)."""


def sidecar_path(csv_path: str | Path) -> Path:
    """The JSON sidecar of a CSV recording: ``FILE.csv`` -> ``FILE.csv.json``."""
    csv_path = Path(csv_path)
    return csv_path.with_name(csv_path.name + ".json")


def save(rec: RecordingFields, path: str | Path) -> Path:
    """Save ``rec`` as ``.npz`` or ``.csv`` according to the file suffix; returns the path."""
    path = Path(path)
    if path.suffix == ".npz":
        return save_npz(rec, path)
    if path.suffix == ".csv":
        return save_csv(rec, path)
    raise RecordingError(f"{path}: unknown recording format; expected .npz or .csv")


def save_npz(rec: RecordingFields, path: str | Path) -> Path:
    """Save ``rec`` losslessly (dtypes kept) as a compressed NPZ file; returns the path."""
    path = Path(path)
    arrays: dict[str, Any] = {
        "emg": rec.emg,
        "fs_hz": np.float64(rec.fs_hz),
        "channel_names": np.array(rec.channel_names),
        "emg_unit": np.array(rec.emg_unit),
        "metadata_json": np.array(json.dumps(rec.metadata, sort_keys=True)),
    }
    for name in ("force_n", "intent", "intent_force_n", "pitch_rad", "open_intent"):
        value = getattr(rec, name)
        if value is not None:
            arrays[name] = value
    np.savez_compressed(path, **arrays)
    return path


def save_csv(rec: RecordingFields, path: str | Path) -> Path:
    """Save ``rec`` as griploop's CSV plus its JSON sidecar; returns the CSV's path.

    See the module docstring for the layout; the sidecar holds the sampling
    rate, sEMG unit, channel names, column units and metadata.
    """
    path = Path(path)
    header = ["t"] + [f"emg{i + 1}" for i in range(rec.n_channels)]
    columns = [rec.t_s[:, None], rec.emg.astype(float)]
    formats = ["%.6f"] + (["%d"] if rec.emg.dtype.kind in "iu" else ["%.6g"]) * rec.n_channels
    units = {"t": "s", **{name: rec.emg_unit for name in header[1:]}}
    if rec.force_n is not None:
        header.append("force")
        columns.append(rec.force_n[:, None])
        formats.append("%.6g")
        units["force"] = "N"
    for name in OPTIONAL_COLUMNS:
        value = getattr(rec, name)
        if value is not None:
            header.append(name)
            columns.append(value[:, None])
            formats.append("%.6g")
            units[name] = {"intent": "1 (0..1 of MVC)", "pitch_rad": "rad",
                           "open_intent": "1 (0..1 of the largest opening)"}.get(name, "N")
    np.savetxt(path, np.hstack(columns), fmt=formats, delimiter=",",
               header=",".join(header), comments="")
    meta = {
        "format": "griploop recording CSV sidecar",
        "version": 1,
        "csv": path.name,
        "columns": header,
        "units": units,
        "fs_hz": rec.fs_hz,
        "emg_unit": rec.emg_unit,
        "channel_names": rec.channel_names,
        "metadata": rec.metadata,
    }
    sidecar_path(path).write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
    return path
