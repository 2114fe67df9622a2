"""MAV, RMS and WL over sliding windows, as samples arrive in chunks of any length.

:func:`estimation.features.emg_features` computes every window of a whole recording. A
trial receives its sEMG as it happens: a virtual subject's chunk per control step, a
recording's samples as the trial's clock reaches them, an LSL stream's samples one at a
time. :class:`FeatureWindow` keeps the last ``window - 1`` samples of the selected
channels and issues the features of every window that a chunk completes, so that every
trial, simulated, replayed or live, windows its sEMG the same way:

- integer counts (MYO int8) are summed as exact integers, so a window's features are the
  very floats :func:`~estimation.features.emg_features` computes from its integer
  prefix sums (``sum / window``, ``sqrt(sum / window)``, the WL sum);
- float samples are summed over the window directly; the batch takes differences of
  prefix sums, so the two agree to the last bits (``tests/portable.py``).

Window ``j`` covers samples ``[j*step, j*step + window)`` counted from the last
:meth:`FeatureWindow.reset` (paper: 400 ms every 125 ms, 80/25 samples at 200 Hz).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.features import FEATURES, FeatureError, window_samples


class FeatureWindow:
    """Windowed features of selected channels, chunk by chunk (module notes).

    Parameters
    ----------
    fs_hz : float
        Sampling rate, Hz.
    channel_index : sequence of int
        Zero-based columns of the incoming samples to use, in output order.
    window_ms, step_ms : float
        Window length and increment, ms (defaults: the paper's 400 and 125).
    features : sequence of {"mav", "rms", "wl"}
        Features per channel, in output order (channel-major rows, as
        :func:`estimation.features.emg_features`).
    integer : bool
        The samples are integer counts (int8 MYO data): sums are exact integers.

    Attributes
    ----------
    window, step : int
        Window length and increment in samples.
    count : int
        Samples pushed since the last reset.
    n_windows : int
        Windows issued since the last reset.
    dtype : numpy.dtype
        What the sums run in: int64 when ``integer``, else float64.
    """

    def __init__(self, fs_hz: float, channel_index: Sequence[int], *,
                 window_ms: float = 400.0, step_ms: float = 125.0,
                 features: Sequence[str] = FEATURES, integer: bool = True) -> None:
        unknown = [f for f in features if f not in FEATURES]
        if unknown or not features:
            raise FeatureError(
                f"unknown features {unknown or list(features)}; expected a subset of {FEATURES}"
            )
        self.window, self.step = window_samples(fs_hz, window_ms, step_ms)
        self.channel_index = np.asarray(channel_index, dtype=np.intp)
        if self.channel_index.ndim != 1 or self.channel_index.size == 0:
            raise FeatureError(f"channel_index: expected at least one channel, found "
                               f"{list(channel_index)}")
        self.features = tuple(features)
        self.integer = bool(integer)
        self.dtype = np.dtype(np.int64 if self.integer else np.float64)
        self.n_features = self.channel_index.size * len(self.features)
        contiguous = np.array_equal(self.channel_index, np.arange(
            self.channel_index[0], self.channel_index[0] + self.channel_index.size))
        self._columns: slice | np.ndarray = (
            slice(int(self.channel_index[0]), int(self.channel_index[-1]) + 1) if contiguous
            else self.channel_index)
        self._none = np.empty((0, self.n_features))
        self.reset()

    def reset(self) -> None:
        """Forget every sample: the next window starts with the next sample."""
        self._tail = np.empty((0, self.channel_index.size), dtype=self.dtype)
        self.count = 0
        self.n_windows = 0

    def next_end(self) -> int:
        """Index of the last sample of the next window (counted from the reset)."""
        return self.window - 1 + self.n_windows * self.step

    def push(self, samples: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Add a chunk of samples; the features of every window it completes.

        Parameters
        ----------
        samples : ndarray, shape (m, n_channels_in)
            The next ``m`` samples of every incoming channel (any real dtype).

        Returns
        -------
        rows : ndarray, shape (n_completed, n_channels * n_features)
            Each completed window's features, oldest first.
        ends : ndarray of int, shape (n_completed,)
            The index of each window's last sample, counted from the reset.
        """
        m = samples.shape[0]
        first = self.next_end()
        last = self.count + m - 1
        x = samples[:, self._columns]
        if last < first:  # no window ends in this chunk: keep the tail
            self._keep(x)
            return self._none, np.empty(0, dtype=np.intp)
        buf = np.concatenate([self._tail, x.astype(self.dtype, copy=False)])
        base = self.count - self._tail.shape[0]  # sample index of buf[0]
        ends = np.arange(first, last + 1, self.step)
        rows = np.empty((ends.size, self.n_features))
        for i, end in enumerate(ends.tolist()):
            self._features(buf[end + 1 - self.window - base:end + 1 - base], rows[i])
        self.n_windows += ends.size
        self.count += m
        self._tail = buf[max(buf.shape[0] - self.window + 1, 0):]
        return rows, ends

    def _keep(self, x: np.ndarray) -> None:
        """Append ``x`` to the tail, keeping the last ``window - 1`` samples."""
        keep = self.window - 1
        if x.shape[0] >= keep:
            self._tail = x[x.shape[0] - keep:].astype(self.dtype)
        else:
            tail = np.concatenate([self._tail, x.astype(self.dtype, copy=False)])
            self._tail = tail[max(tail.shape[0] - keep, 0):]
        self.count += x.shape[0]

    def _features(self, w: np.ndarray, out: np.ndarray) -> None:
        """One window's features (channel-major) into ``out``."""
        n_feat = len(self.features)
        win = self.window
        for k, name in enumerate(self.features):
            if name == "mav":
                out[k::n_feat] = np.abs(w).sum(axis=0) / win
            elif name == "rms":
                out[k::n_feat] = np.sqrt(np.einsum("ij,ij->j", w, w) / win)
            else:
                out[k::n_feat] = np.abs(np.diff(w, axis=0)).sum(axis=0)
