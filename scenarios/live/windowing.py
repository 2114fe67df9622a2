"""MAV, RMS and WL over sliding windows, updated one sample at a time.

:func:`estimation.features.emg_features` computes every window of a recording from
prefix sums; a live session receives one sample at a time and needs each window's
features the moment its last sample arrives. :class:`IncrementalFeatures` keeps the
same prefix sums (``|x|``, ``x^2`` and ``|x(k) - x(k-1)|``, per channel) in a ring of
``window + 1`` entries and issues a feature row whenever a window completes, so that
on the same samples it gives the same rows (integer counts bit for bit, float samples to
the last bits):

- integer counts (MYO int8) are summed exactly as integers, so a window sum is the
  same integer ``extract_features`` gets from its int32 prefix sums;
- float samples are accumulated sequentially in float64 as ``numpy.cumsum`` does, and a
  window sum is the same difference of two prefix values (the tests allow the last
  bits, as for any two code paths: ``tests/portable.py``).

Window ``j`` covers samples ``[j*step, j*step + win)`` counted from the last
:meth:`IncrementalFeatures.reset` (paper: 400 ms every 125 ms, 80/25 samples at
200 Hz). :meth:`IncrementalFeatures.push` allocates nothing once constructed.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.features import FEATURES, FeatureError, window_samples


class IncrementalFeatures:
    """Windowed features of selected channels, one sample at a time.

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
        Otherwise they are float64 sums accumulated in sample order.

    Attributes
    ----------
    window, step : int
        Window length and increment in samples.
    n_windows : int
        Windows issued since the last reset.
    dtype : numpy.dtype
        What :meth:`push` takes: int64 when ``integer``, else float64.
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
        dtype = np.int64 if self.integer else np.float64
        n_ch = self.channel_index.size
        # ring[slot] holds the prefix sums after `count` samples, slot = count % (win + 1);
        # rows 0, 1, 2: sum |x|, sum x^2, sum |dx| (the latter over count - 1 differences)
        self._ring = np.zeros((self.window + 1, 3, n_ch), dtype=dtype)
        self._acc = np.zeros((3, n_ch), dtype=dtype)
        self._x = np.zeros(n_ch, dtype=dtype)
        self._prev = np.zeros(n_ch, dtype=dtype)
        self._tmp = np.zeros(n_ch, dtype=dtype)
        self._out = np.zeros((n_ch, len(self.features)))
        self._row = self._out.reshape(-1)
        self.dtype = np.dtype(dtype)
        self.reset()

    def reset(self) -> None:
        """Forget every sample: the next window starts with the next sample."""
        self._ring[:] = 0
        self._acc[:] = 0
        self.count = 0
        self.n_windows = 0

    def push(self, sample: np.ndarray) -> np.ndarray | None:
        """Add one sample; return the completed window's features, or ``None``.

        Parameters
        ----------
        sample : ndarray, shape (n_channels_in,)
            One sample of every incoming channel: int64 counts when ``integer``,
            else float64 (``dtype``).

        Returns
        -------
        ndarray, shape (n_channels * n_features,) or None
            The features of the window ending with this sample (a buffer reused by
            the next call: copy it to keep it), else ``None``.
        """
        x, acc, tmp = self._x, self._acc, self._tmp
        np.take(sample, self.channel_index, out=x)
        np.abs(x, out=tmp)
        acc[0] += tmp
        np.multiply(x, x, out=tmp)
        acc[1] += tmp
        if self.count > 0:
            np.subtract(x, self._prev, out=tmp)
            np.abs(tmp, out=tmp)
            acc[2] += tmp
        self._prev[:] = x
        self.count += 1
        win = self.window
        self._ring[self.count % (win + 1)] = acc
        start = self.count - win
        if start < 0 or start % self.step:
            return None
        ring = self._ring
        old = ring[start % (win + 1)]
        # the |dx| sums run one behind: after c samples they hold c - 1 differences, so
        # the window's first difference (start -> start + 1) follows the prefix stored
        # after start + 1 samples, and the accumulator ends at difference start + win - 1
        old_wl = ring[(start + 1) % (win + 1), 2]
        out = self._out
        for k, name in enumerate(self.features):
            if name == "mav":
                out[:, k] = (acc[0] - old[0]) / win
            elif name == "rms":
                out[:, k] = np.sqrt((acc[1] - old[1]) / win)
            else:
                out[:, k] = acc[2] - old_wl
        self.n_windows += 1
        return self._row
