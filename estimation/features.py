"""Windowed time-domain sEMG features: MAV, RMS and WL (paper eqs. 1-3).

Windows are defined in milliseconds so that any sampling rate works; the
paper uses 400 ms windows every 125 ms. Window ``j`` covers samples
``[j*step, j*step + win)`` and its estimate is issued at the time of its
last sample, ``t_s[j] = (j*step + win - 1) / fs_hz``.

All sums are computed from prefix sums, so extraction is O(n_samples) and
fully vectorized whatever the overlap.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sim.errors import GriploopError
from sim.recording import Recording, RecordingError

FEATURES = ("mav", "rms", "wl")
PAPER_CHANNELS = (6, 7, 8)  # FCU, PL, FCR (paper Table 1), 1-based
TARGET_ALIGNMENTS = ("last", "mean")


class FeatureError(GriploopError, ValueError):
    """Feature extraction was asked for something the signal cannot give."""


@dataclass(frozen=True)
class FeatureSet:
    """Features of one recording, one row per window.

    Attributes
    ----------
    X : ndarray, shape (n_windows, n_channels * n_features)
        Columns are channel-major: ``ch6_mav, ch6_rms, ch6_wl, ch7_mav, ...``.
    y : ndarray, shape (n_windows,) or None
        Target force in newtons aligned to each window (see ``target``).
    intent : ndarray, shape (n_windows,) or None
        Ground-truth normalized intent aligned the same way (simulations).
    t_s : ndarray, shape (n_windows,)
        Time of each window's last sample, seconds.
    names : tuple of str
        Column names of ``X``.
    dt_s : float
        Window increment in seconds (the estimator's sample time Ts).
    """

    X: np.ndarray
    y: np.ndarray | None
    intent: np.ndarray | None
    t_s: np.ndarray
    names: tuple[str, ...]
    dt_s: float

    @property
    def n_windows(self) -> int:
        """Number of windows."""
        return int(self.X.shape[0])

    def columns(self, feature: str) -> np.ndarray:
        """The columns of ``X`` holding one feature type (e.g. ``"mav"``), all channels."""
        idx = [i for i, name in enumerate(self.names) if name.endswith("_" + feature)]
        if not idx:
            raise FeatureError(f"feature {feature!r} not extracted; have {self.names}")
        return self.X[:, idx]


def window_samples(fs_hz: float, window_ms: float, step_ms: float) -> tuple[int, int]:
    """Window length and increment in samples for a sampling rate.

    Rounded to the nearest sample; at 200 Hz the paper's 400/125 ms give 80/25.

    Raises
    ------
    FeatureError
        If either is shorter than 2 (window) or 1 (step) samples.
    """
    win = int(round(window_ms * fs_hz / 1000.0))
    step = int(round(step_ms * fs_hz / 1000.0))
    if win < 2 or step < 1:
        raise FeatureError(
            f"window {window_ms} ms / step {step_ms} ms at {fs_hz} Hz gives {win}/{step} samples; "
            "expected a window of at least 2 samples and a step of at least 1"
        )
    return win, step


def _window_sums(prefix: np.ndarray, starts: np.ndarray, length: int) -> np.ndarray:
    """Sums over ``[s, s+length)`` along the last axis from a prefix sum with a leading zero."""
    return prefix[..., starts + length] - prefix[..., starts]


def _prefix(values: np.ndarray, dtype: type) -> np.ndarray:
    """Prefix sums along the last axis with a leading zero column."""
    out = np.zeros(values.shape[:-1] + (values.shape[-1] + 1,), dtype=dtype)
    np.cumsum(values, axis=-1, dtype=dtype, out=out[..., 1:])
    return out


def emg_features(
    emg: np.ndarray,
    fs_hz: float,
    *,
    window_ms: float = 400.0,
    step_ms: float = 125.0,
    features: Sequence[str] = FEATURES,
) -> np.ndarray:
    """MAV, RMS and WL of every channel over sliding windows.

    Parameters
    ----------
    emg : ndarray, shape (n_samples, n_channels)
        Raw sEMG: 8-bit counts (MYO) or float values in any unit.
    fs_hz : float
        Sampling rate in hertz.
    window_ms, step_ms : float
        Window length and increment in milliseconds.
    features : sequence of {"mav", "rms", "wl"}
        Which features, in output order within each channel.

    Returns
    -------
    ndarray, shape (n_windows, n_channels * len(features))
        Channel-major columns. MAV = mean ``|x|`` (eq. 1), RMS = sqrt(mean x^2)
        (eq. 2), WL = sum of ``|x(k) - x(k-1)|`` over the window's consecutive
        sample pairs (eq. 3, ``win - 1`` terms).

    Notes
    -----
    Window sums are differences of prefix sums taken along contiguous
    per-channel rows. For 8-bit input the prefix sums run in int32, which is
    several times faster than float64; they may wrap around on long
    recordings, but a difference of two wrapped sums is still exact as long as
    one window's sum fits in int32 (checked), so the result equals the float
    computation bit for bit.
    """
    x = np.asarray(emg)
    if x.ndim != 2:
        raise FeatureError(f"emg must be 2-D (n_samples, n_channels), found shape {x.shape}")
    unknown = [f for f in features if f not in FEATURES]
    if unknown or not features:
        raise FeatureError(
            f"unknown features {unknown or features}; expected a subset of {FEATURES}"
        )
    if x.dtype.kind not in "iuf":
        raise FeatureError(f"emg must be numeric, found dtype {x.dtype}")
    if x.dtype.kind == "f" and not np.all(np.isfinite(x)):
        raise FeatureError("emg contains NaN or inf")
    win, step = window_samples(fs_hz, window_ms, step_ms)
    n, c = x.shape
    if n < win:
        raise FeatureError(
            f"recording has {n} samples, fewer than one {window_ms} ms window ({win} samples)"
        )
    starts = np.arange(0, n - win + 1, step)
    # int32 is exact when a window's largest possible sum of squares fits.
    exact_int = x.dtype.kind in "iu" and x.dtype.itemsize == 1 and win * 255**2 < 2**31
    acc = np.int32 if exact_int else np.float64
    rows = np.ascontiguousarray(x.T, dtype=acc)  # (n_channels, n_samples)
    out = np.empty((starts.size, c, len(features)))
    for k, name in enumerate(features):
        if name == "mav":
            out[:, :, k] = (_window_sums(_prefix(np.abs(rows), acc), starts, win) / win).T
        elif name == "rms":
            sums = _window_sums(_prefix(rows * rows, acc), starts, win)
            out[:, :, k] = np.sqrt(sums / win).T
        else:  # wl: d[i] = |x[i+1] - x[i]|; the window starting at s uses d[s : s+win-1]
            diffs = np.abs(np.diff(rows, axis=1))
            out[:, :, k] = _window_sums(_prefix(diffs, acc), starts, win - 1).T
    return out.reshape(starts.size, c * len(features))


def align_to_windows(
    signal: np.ndarray, fs_hz: float, *, window_ms: float = 400.0, step_ms: float = 125.0,
    target: str = "last",
) -> np.ndarray:
    """A per-sample signal (force, intent) aligned to the feature windows.

    Parameters
    ----------
    signal : ndarray, shape (n_samples,)
    target : {"last", "mean"}
        ``"last"``: the value at each window's last sample, i.e. at the instant
        the estimate is issued (default, causal). ``"mean"``: the window mean.

    Returns
    -------
    ndarray, shape (n_windows,)
    """
    s = np.asarray(signal, dtype=float)
    if target not in TARGET_ALIGNMENTS:
        raise FeatureError(f"target must be one of {TARGET_ALIGNMENTS}, found {target!r}")
    win, step = window_samples(fs_hz, window_ms, step_ms)
    if s.ndim != 1 or s.size < win:
        raise FeatureError(f"signal must be 1-D with at least {win} samples, found {s.shape}")
    starts = np.arange(0, s.size - win + 1, step)
    if target == "last":
        return s[starts + win - 1]
    return _window_sums(_prefix(s, np.float64), starts, win) / win


def extract_features(
    recording: Recording,
    *,
    channels: Sequence[int | str] | None = PAPER_CHANNELS,
    window_ms: float = 400.0,
    step_ms: float = 125.0,
    features: Sequence[str] = FEATURES,
    target: str = "last",
) -> FeatureSet:
    """Features of selected channels with the force (and intent) aligned to each window.

    Parameters
    ----------
    recording : Recording
    channels : sequence of int (1-based) or str, optional
        Channels to use; the paper uses 6, 7, 8. ``None`` means all.
    window_ms, step_ms, features, target
        See :func:`emg_features` and :func:`align_to_windows`.

    Raises
    ------
    RecordingError
        For an unknown channel.
    FeatureError
        For a recording shorter than one window or unusable settings.
    """
    if channels is None:
        idx = list(range(recording.n_channels))
    else:
        idx = [recording.channel_index(ch) for ch in channels]
        if len(set(idx)) != len(idx):
            raise RecordingError(f"{recording.source}: channels {list(channels)} repeat a channel")
    X = emg_features(recording.emg[:, idx], recording.fs_hz, window_ms=window_ms,
                     step_ms=step_ms, features=features)
    kw = dict(window_ms=window_ms, step_ms=step_ms)
    y = None if recording.force_n is None else align_to_windows(
        recording.force_n, recording.fs_hz, target=target, **kw)
    intent = None if recording.intent is None else align_to_windows(
        recording.intent, recording.fs_hz, target=target, **kw)
    win, step = window_samples(recording.fs_hz, window_ms, step_ms)
    t_s = (np.arange(X.shape[0]) * step + win - 1) / recording.fs_hz
    names = tuple(f"{recording.channel_names[i]}_{f}" for i in idx for f in features)
    return FeatureSet(X=X, y=y, intent=intent, t_s=t_s, names=names,
                      dt_s=step / recording.fs_hz)
