"""Labels, labelled windows, calibration errors and checks shared by the open/close decoders.

A decoder is fitted on labelled windows (:func:`decoder_windows`: 0 rest, 1 close, 2
open). Its calibration sets each amplitude's rest level (median at rest) and largest
contraction (95th percentile over its own class's windows, :func:`class_levels`), and is
refused in one line when a class is missing or never rises above rest.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.errors import EstimationInputError
from estimation.features import align_to_windows, emg_features
from sim.errors import GriploopError

#: Window labels: rest, close (a squeeze), open (an opening contraction).
REST, CLOSE, OPEN = 0, 1, 2
LABELS = (REST, CLOSE, OPEN)
LABEL_NAMES = ("rest", "close", "open")

#: A contraction class must rise above the rest level by at least this fraction of the
#: rest level (and by more than ``MIN_RISE``) for its calibration to be accepted.
MIN_RISE_FRACTION = 0.1
#: The smallest rise above rest accepted in any unit (guards a rest level of zero).
MIN_RISE = 1e-9
#: The percentile of a class's amplitude taken as its largest contraction.
MAX_PERCENTILE = 95.0


class DecoderCalibrationError(GriploopError, ValueError):
    """A decoder calibration cannot set its levels: a class missing, or a site that never
    rises above its rest level (the message names the site's channels)."""


class NoOpenContractionsError(DecoderCalibrationError):
    """A decoder calibration has no open contractions (a recording of squeezes only)."""


def decoder_windows(emg: np.ndarray, intent: np.ndarray, open_intent: np.ndarray | None, *,
                    fs_hz: float, window_ms: float = 400.0, step_ms: float = 125.0,
                    on: float = 0.1, off: float = 0.05
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The labelled MAV windows of one recording, for a decoder's ``fit`` or for judging a decoder.

    Parameters
    ----------
    emg : ndarray, shape (n_samples, n_channels)
        Raw sEMG (int8 counts, or floats).
    intent : ndarray, shape (n_samples,)
        Close intent, 0..1 (fraction of MVC).
    open_intent : ndarray, shape (n_samples,), or None
        Open intent, 0..1; ``None``: a recording without it (no open windows).
    fs_hz : float
        Sampling rate, Hz.
    window_ms, step_ms : float
        Window length and increment, ms (the paper's 400 and 125).
    on, off : float
        Intent above which a window is a contraction, and below which it is rest.

    Returns
    -------
    X : ndarray, shape (n_kept, n_channels)
        MAV of every channel in the labelled windows (LSB for int8 input).
    y : ndarray of int, shape (n_kept,)
        0 rest, 1 close, 2 open, from the intents at each window's last sample: open if
        the open intent is at least ``on`` and above the close intent, else close if the
        close intent is at least ``on``, rest if both are below ``off``.
    kept : ndarray of bool, shape (n_windows,)
        Which of all the recording's windows were kept; the others (an intent between
        ``off`` and ``on``: a contraction's rise or fall) are ambiguous and dropped.

    Raises
    ------
    estimation.features.FeatureError
        sEMG that is not 2-D, or shorter than one window.
    EstimationInputError
        Intents of another length than the sEMG, or ``off > on``.
    """
    X = emg_features(emg, fs_hz, window_ms=window_ms, step_ms=step_ms, features=("mav",))
    n = np.shape(emg)[0]
    close = np.asarray(intent, dtype=float)
    opening = np.zeros(n) if open_intent is None else np.asarray(open_intent, float)
    if close.shape != (n,) or opening.shape != (n,):
        raise EstimationInputError(
            f"decoder windows: expected intents of shape ({n},) like the sEMG's samples, "
            f"found {close.shape} and {opening.shape}")
    if not 0.0 <= off <= on:
        raise EstimationInputError(f"decoder windows: expected 0 <= off <= on, found off "
                                   f"{off}, on {on}")
    c = align_to_windows(close, fs_hz, window_ms=window_ms, step_ms=step_ms)
    o = align_to_windows(opening, fs_hz, window_ms=window_ms, step_ms=step_ms)
    is_open = (o >= on) & (o > c)
    is_close = (c >= on) & ~is_open
    is_rest = (c < off) & (o < off)
    y = np.full(c.shape, -1, dtype=np.intp)
    y[is_rest], y[is_close], y[is_open] = REST, CLOSE, OPEN
    kept = y >= 0
    return X[kept], y[kept], kept


def check_labels(y: np.ndarray, n_windows: int) -> np.ndarray:
    """``y`` as int labels in {0, 1, 2} of length ``n_windows``.

    Raises
    ------
    EstimationInputError
        Another shape, or a label outside {0, 1, 2}.
    """
    arr = np.asarray(y)
    if arr.shape != (n_windows,):
        raise EstimationInputError(f"y must have shape ({n_windows},), found {arr.shape}")
    if arr.size and not np.all(np.isin(arr, LABELS)):
        bad = arr[~np.isin(arr, LABELS)][0]
        raise EstimationInputError(f"y: expected labels 0 (rest), 1 (close), 2 (open), "
                                   f"found {bad!r}")
    return arr.astype(np.intp)


def check_fractions(who: str, on_fraction: float, off_fraction: float) -> None:
    """Refuse thresholds outside ``0 <= off_fraction <= on_fraction < 1``.

    Raises
    ------
    EstimationInputError
    """
    if not 0.0 <= off_fraction <= on_fraction < 1.0:
        raise EstimationInputError(f"{who}: expected 0 <= off_fraction <= on_fraction < 1, "
                                   f"found off_fraction {off_fraction}, on_fraction "
                                   f"{on_fraction}")


def require_classes(who: str, y: np.ndarray) -> None:
    """Refuse a calibration without rest, close or open windows.

    Raises
    ------
    NoOpenContractionsError
        No open windows (checked before the others: a recording of squeezes only).
    DecoderCalibrationError
        No rest or no close windows.
    """
    counts = np.bincount(y, minlength=3)
    if counts[OPEN] == 0:
        raise NoOpenContractionsError(
            f"{who}: the calibration has no open contractions (0 open windows among "
            f"{y.size}); expected a session of open contractions")
    for label in (REST, CLOSE):
        if counts[label] == 0:
            what = "rest" if label == REST else "close contractions (squeezes)"
            raise DecoderCalibrationError(f"{who}: the calibration has no {what} (0 "
                                          f"{LABEL_NAMES[label]} windows among {y.size})")


def class_levels(who: str, what: str, amplitude: np.ndarray, y: np.ndarray,
                 label: int) -> tuple[float, float]:
    """The rest level and the largest contraction of one amplitude, as clinicians set them.

    Parameters
    ----------
    who, what : str
        The decoder and the site (with its channels), for the message.
    amplitude : ndarray, shape (n_windows,)
        The site's amplitude per window (mean MAV of its channels).
    y : ndarray of int, shape (n_windows,)
    label : int
        The class whose windows give the largest contraction.

    Returns
    -------
    rest, largest : float
        Median at rest windows; ``MAX_PERCENTILE``-th percentile over ``label``'s windows.

    Raises
    ------
    DecoderCalibrationError
        ``largest`` does not rise above ``rest`` by ``MIN_RISE_FRACTION`` of it.
    """
    rest = float(np.median(amplitude[y == REST]))
    largest = float(np.percentile(amplitude[y == label], MAX_PERCENTILE))
    if largest - rest <= max(MIN_RISE_FRACTION * abs(rest), MIN_RISE):
        name = LABEL_NAMES[label]
        raise DecoderCalibrationError(
            f"{who}: {what} never rises above its rest level (rest {rest:.3g} LSB, largest "
            f"{largest:.3g} LSB); expected {name} contractions in the calibration")
    return rest, largest


def channel_text(channels: Sequence[int]) -> str:
    """``"channels 3, 4, 5"`` (1-based, as given)."""
    return "channels " + ", ".join(str(int(c)) for c in channels)


def decoded_labels(decoded: np.ndarray) -> np.ndarray:
    """Labels of decoded levels: 1 where close > 0, 2 where open > 0, else 0.

    Parameters
    ----------
    decoded : ndarray, shape (n_windows, 2)

    Returns
    -------
    ndarray of int, shape (n_windows,)
    """
    d = np.asarray(decoded, dtype=float)
    labels = np.zeros(d.shape[0], dtype=np.intp)
    labels[d[:, 0] > 0.0] = CLOSE
    labels[d[:, 1] > 0.0] = OPEN
    return labels
