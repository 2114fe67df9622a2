"""One sEMG + force recording, simulated or real, and its NPZ/CSV file formats.

A :class:`Recording` is what a MYO armband and an FSR produce in one session:
multichannel sEMG of shape ``(n_samples, n_channels)`` sampled at ``fs_hz``, the
measured grip force in newtons (optional), and, for simulated subjects, the
ground-truth intent (normalized force, 0..1) that produced them; a calibration for a
hand that opens on a second signal also labels its open contractions (``open_intent``,
optional).

One module per job; the names below are the package's interface:

- :mod:`sim.recording.core`: the :class:`Recording` type and its checks;
- :mod:`sim.recording.writing`: ``Recording.save`` to NPZ, or CSV with a JSON
  sidecar (:func:`sidecar_path`);
- :mod:`sim.recording.reading`: :func:`load_recording` and the hardened NPZ reader;
- :mod:`sim.recording.csv_import`: CSV files, griploop's own and other tools';
- :mod:`sim.recording.columns`: :class:`ColumnMap` and column-map files
  (:func:`read_column_file`);
- :mod:`sim.recording.errors`: :class:`RecordingError`, with the layout option at
  fault and the :class:`Fix` that gets past it as data;
- :mod:`sim.recording.checks`: units and limits.

``docs/FORMAT.md`` documents the formats and options.
"""

from sim.recording.checks import (
    DUPLICATES,
    EMG_UNITS,
    MAX_CSV_COLUMNS,
    MAX_EMG_ABS,
    MAX_FILE_BYTES,
    MAX_FORCE_N,
    MAX_FS_HZ,
    MAX_GAP_STEPS,
    MAX_INTENT,
    MAX_SIDECAR_BYTES,
    MIN_FS_HZ,
    TIME_UNITS,
)
from sim.recording.columns import ColumnMap, read_column_file
from sim.recording.core import Recording
from sim.recording.errors import OPTIONS, Fix, RecordingError
from sim.recording.reading import load_recording
from sim.recording.writing import sidecar_path

__all__ = [
    "DUPLICATES", "EMG_UNITS", "MAX_CSV_COLUMNS", "MAX_EMG_ABS", "MAX_FILE_BYTES",
    "MAX_FORCE_N", "MAX_FS_HZ", "MAX_GAP_STEPS", "MAX_INTENT", "MAX_SIDECAR_BYTES",
    "MIN_FS_HZ", "OPTIONS", "TIME_UNITS", "ColumnMap", "Fix", "Recording", "RecordingError",
    "load_recording", "read_column_file", "sidecar_path",
]
