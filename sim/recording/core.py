"""The :class:`Recording` type: one sEMG + force recording, simulated or real.

A :class:`Recording` is what a MYO armband and an FSR produce in one session:
multichannel sEMG of shape ``(n_samples, n_channels)`` sampled at ``fs_hz``, the
measured grip force in newtons (optional), and, for simulated subjects, the
ground-truth intent (normalized force, 0..1) that produced them. Constructing one
checks every array (:class:`~sim.recording.errors.RecordingError` otherwise), so a
recording that exists is a valid one, whatever file it came from.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sim.recording import writing
from sim.recording.checks import (
    EMG_UNITS,
    MAX_EMG_ABS,
    MAX_FORCE_N,
    MAX_INTENT,
    MAX_PITCH_RAD,
    positive_rate,
)
from sim.recording.errors import RecordingError


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
    pitch_rad : ndarray, shape (n_samples,), optional
        Forearm pitch from the armband's IMU at each sEMG sample, rad (what
        ``griploop live --imu-lsl`` turns into the wrist's height); a virtual
        subject's grasp recording derives it from the simulated wrist height.
    open_intent : ndarray, shape (n_samples,), optional
        Ground-truth intended opening (finger extension), 0..1 of the largest opening
        contraction: labels the open contractions of a calibration for a hand that opens
        on a second signal (``griploop calibrate --open``; a virtual subject's
        ``open_session``). Optional: a recording without it is a squeeze-only
        (single-site) calibration, any lab's CSV included.
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
    pitch_rad: np.ndarray | None = None
    open_intent: np.ndarray | None = None
    metadata: dict[str, Any] = field(default_factory=dict)
    source: str = "<array>"

    def __post_init__(self) -> None:
        self.emg = self._checked_emg()
        n, c = self.emg.shape
        self.channel_names = self._checked_names(c)
        for name in ("force_n", "intent", "intent_force_n", "pitch_rad", "open_intent"):
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, self._checked_series(name, value, n))
        if not isinstance(self.metadata, dict):
            raise RecordingError(
                f"{self.source}: metadata: expected a JSON object, "
                f"found {type(self.metadata).__name__}"
            )

    def _checked_emg(self) -> np.ndarray:
        """``emg`` as an array, checked against its shape, unit and limits (and ``fs_hz``)."""
        src = self.source
        emg = np.asarray(self.emg)
        if emg.ndim != 2:
            raise RecordingError(
                f"{src}: emg must be 2-D (n_samples, n_channels), found shape {emg.shape}"
            )
        if emg.shape[0] == 0 or emg.shape[1] == 0:
            raise RecordingError(f"{src}: emg is empty, shape {emg.shape}")
        self.fs_hz = positive_rate(self.fs_hz, src, "fs_hz")
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
        return emg

    def _checked_names(self, c: int) -> list[str]:
        """``channel_names`` as ``c`` strings (default ``emg1..emgN``)."""
        names = self.channel_names
        if names is None:
            return [f"emg{i + 1}" for i in range(c)]
        if isinstance(names, (str, bytes)) or not hasattr(names, "__len__"):
            raise RecordingError(
                f"{self.source}: channel_names: expected a list of {c} names, "
                f"found {type(names).__name__}"
            )
        if len(names) != c:
            raise RecordingError(f"{self.source}: {len(names)} channel names for {c} channels")
        return [str(name) for name in names]

    def _checked_series(self, name: str, value: Any, n: int) -> np.ndarray:
        """One of the per-sample series (``force_n``, ``intent``, ``intent_force_n``,
        ``pitch_rad``, ``open_intent``) as ``n`` finite floats in range."""
        src = self.source
        raw = np.asarray(value)
        if raw.dtype.kind not in "iuf":
            raise RecordingError(f"{src}: {name}: expected real numbers, found dtype {raw.dtype}")
        arr = raw.astype(float)
        if arr.shape != (n,):
            raise RecordingError(
                f"{src}: {name} must have shape ({n},) to match emg, found {arr.shape}"
            )
        if not np.all(np.isfinite(arr)):
            raise RecordingError(f"{src}: column {name} contains NaN or inf")
        limit, unit = {"intent": (MAX_INTENT, ""), "open_intent": (MAX_INTENT, ""),
                       "pitch_rad": (MAX_PITCH_RAD, " rad")}.get(name, (MAX_FORCE_N, " N"))
        if name == "open_intent" and (arr.min() < 0.0 or arr.max() > 1.0):
            raise RecordingError(
                f"{src}: open_intent: expected values in 0..1, found "
                f"{float(arr.min()):.6g}..{float(arr.max()):.6g}"
            )
        peak = float(np.max(np.abs(arr)))
        if peak > limit:
            raise RecordingError(
                f"{src}: {name}: expected |values| <= {limit:g}{unit}, found {peak:.6g}"
            )
        return arr

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
            pitch_rad=cut(self.pitch_rad),
            open_intent=cut(self.open_intent),
            metadata=dict(self.metadata),
            source=self.source,
        )

    # --------------------------------------------------------------- file I/O
    def save(self, path: str | Path) -> Path:
        """Save as ``.npz`` or ``.csv`` according to the file suffix."""
        return writing.save(self, path)

    def save_npz(self, path: str | Path) -> Path:
        """Save losslessly (dtypes kept) as a compressed NPZ file."""
        return writing.save_npz(self, path)

    def save_csv(self, path: str | Path) -> Path:
        """Save as plain CSV ``t,emg1..emgN`` with the optional columns ``force``,
        ``intent``, ``intent_force_n``, ``pitch_rad`` and ``open_intent``, plus a JSON
        sidecar.

        The CSV has one header line and one row per sample (``t`` in seconds,
        sEMG in ``emg_unit``, forces in newtons), so ``pandas.read_csv``,
        ``numpy.loadtxt(f, delimiter=",", skiprows=1)`` and spreadsheets read
        it. The sampling rate, sEMG unit, channel names and metadata go to
        ``FILE.csv.json`` (see :func:`~sim.recording.writing.sidecar_path`), which
        :func:`~sim.recording.load_recording` reads back.
        """
        return writing.save_csv(self, path)
