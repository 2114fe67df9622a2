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

from sim.recording import Recording, RecordingError

FEATURES = ("mav", "rms", "wl")
PAPER_CHANNELS = (6, 7, 8)  # FCU, PL, FCR (paper Table 1), 1-based
TARGET_ALIGNMENTS = ("last", "mean")


class FeatureError(ValueError):
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
    """Sums over rows ``[s, s+length)`` from a prefix-sum array with a leading zero row."""
    return prefix[starts + length] - prefix[starts]


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
        Raw sEMG (any numeric dtype; int8 counts are summed exactly in float64).
    fs_hz : float
        Sampling rate in hertz.
    window_ms, step_ms : float
        Window length and increment in milliseconds.
    features : sequence of {"mav", "rms", "wl"}
        Which features, in output order within each channel.

    Returns
    -------
    ndarray, shape (n_windows, n_channels * len(features))
        Channel-major columns. MAV = mean |x| (eq. 1), RMS = sqrt(mean x^2)
        (eq. 2), WL = sum of |x(k) - x(k-1)| over the window's consecutive
        sample pairs (eq. 3, ``win - 1`` terms).
    """
    x = np.asarray(emg)
    if x.ndim != 2:
        raise FeatureError(f"emg must be 2-D (n_samples, n_channels), found shape {x.shape}")
    unknown = [f for f in features if f not in FEATURES]
    if unknown or not features:
        raise FeatureError(f"unknown features {unknown or features}; expected a subset of {FEATURES}")
    x = x.astype(np.float64, copy=False)
    if not np.all(np.isfinite(x)):
        raise FeatureError("emg contains NaN or inf")
    win, step = window_samples(fs_hz, window_ms, step_ms)
    n, c = x.shape
    if n < win:
        raise FeatureError(
            f"recording has {n} samples, fewer than one {window_ms} ms window ({win} samples)"
        )
    starts = np.arange(0, n - win + 1, step)
    out = np.empty((starts.size, c, len(features)))
    zero = np.zeros((1, c))
    for k, name in enumerate(features):
        if name == "mav":
            prefix = np.concatenate([zero, np.cumsum(np.abs(x), axis=0)])
            out[:, :, k] = _window_sums(prefix, starts, win) / win
        elif name == "rms":
            prefix = np.concatenate([zero, np.cumsum(x * x, axis=0)])
            out[:, :, k] = np.sqrt(np.maximum(_window_sums(prefix, starts, win), 0.0) / win)
        else:  # wl: differences d[i] = |x[i+1]-x[i]|; window uses d[s : s+win-1]
            prefix = np.concatenate([zero, np.cumsum(np.abs(np.diff(x, axis=0)), axis=0)])
            out[:, :, k] = _window_sums(prefix, starts, win - 1)
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
    prefix = np.concatenate([[0.0], np.cumsum(s)])
    return _window_sums(prefix, starts, win) / win


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
