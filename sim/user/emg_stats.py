"""Per-recording sEMG statistics used to compare virtual subjects with real MYO recordings.

These are the statistics of docs/SUBJECTS.md's table of real recordings, computed
the same way on real and virtual recordings (int8 MYO counts, any sampling rate):

* windows of 400 ms every 125 ms (the estimator's windows);
* **rest** = the quietest 20 % of windows (by RMS over all channels);
* **active** = windows whose mean force lies in the top 30 % of the recording's
  force range (``force >= min + 0.7 (max - min)``);
* flexor channels 6-8, extensor channels 3-5 (1-based, paper Table 1).

============================  =========================================================
key                           definition
============================  =========================================================
``rest_std_lsb``              std of every rest-window sample of every channel (LSB)
``active_rms_lsb``            RMS of channels 6-8 over the active windows (LSB)
``median_frequency_hz``       median frequency of the mean periodogram of channels
                              6-8 over the active windows (each window detrended)
``adjacent_abs_r``            mean over the 8 ring-adjacent channel pairs of abs(r),
                              samples of the active windows
``saturated_fraction``        fraction of all samples at -128 or 127
``flexor_extensor_ratio``     RMS of channels 6-8 / RMS of channels 3-5, active windows
============================  =========================================================
"""

from __future__ import annotations

import numpy as np

from sim.recording import RecordingError

#: Keys of the statistics :func:`emg_statistics` returns, in order.
STAT_KEYS = ("rest_std_lsb", "active_rms_lsb", "median_frequency_hz", "adjacent_abs_r",
             "saturated_fraction", "flexor_extensor_ratio")

#: Real MYO + FSR recordings of the paper's protocol (10 subjects; docs/SUBJECTS.md):
#: median, min, max over subjects. Not shipped data: the published summary only.
REAL_RANGES = {
    "rest_std_lsb": (2.45, 1.0, 4.7),
    "active_rms_lsb": (32.0, 11.5, 63.0),
    "median_frequency_hz": (68.0, 62.0, 70.0),
    "adjacent_abs_r": (0.45, 0.31, 0.71),
    "saturated_fraction": (7e-4, 9e-5, 9e-3),
    "flexor_extensor_ratio": (1.0, 0.36, 1.19),
}

FLEXOR_CHANNELS = (6, 7, 8)
EXTENSOR_CHANNELS = (3, 4, 5)


def _windows(n: int, fs_hz: float, window_ms: float, step_ms: float) -> np.ndarray:
    win = int(round(window_ms * fs_hz / 1000.0))
    step = max(int(round(step_ms * fs_hz / 1000.0)), 1)
    if n < win:
        raise RecordingError(f"recording has {n} samples; expected at least one {window_ms} ms "
                         f"window ({win} samples)")
    starts = np.arange(0, n - win + 1, step)
    return starts[:, None] + np.arange(win)[None, :]


def emg_statistics(emg: np.ndarray, force_n: np.ndarray, fs_hz: float, *,
                   window_ms: float = 400.0, step_ms: float = 125.0) -> dict[str, float]:
    """The six per-recording statistics of the module docstring.

    Parameters
    ----------
    emg : ndarray, shape (n_samples, 8)
        sEMG in MYO counts (int8 or float holding counts).
    force_n : ndarray, shape (n_samples,)
        Measured grip force (N); selects the active windows.
    fs_hz : float
        Sampling rate in hertz.
    window_ms, step_ms : float
        Window length and increment in milliseconds.

    Returns
    -------
    dict
        One float per key of :data:`STAT_KEYS`.

    Raises
    ------
    ValueError
        ``emg`` does not have 8 channels, lengths differ, or the force is constant.
    """
    x = np.asarray(emg)
    f = np.asarray(force_n, dtype=float)
    if x.ndim != 2 or x.shape[1] != 8:
        raise RecordingError(f"emg: expected shape (n_samples, 8), found {x.shape}")
    if f.shape != (x.shape[0],):
        raise RecordingError(f"force_n: expected shape ({x.shape[0]},), found {f.shape}")
    saturated = float(np.mean((x <= -128) | (x >= 127)))
    x = x.astype(float)
    idx = _windows(x.shape[0], fs_hz, window_ms, step_ms)
    xw = x[idx]  # (n_windows, win, 8)
    power = np.mean(xw**2, axis=(1, 2))
    n_rest = max(int(round(0.2 * power.size)), 1)
    rest = np.argsort(power, kind="stable")[:n_rest]
    fw = f[idx].mean(axis=1)
    lo, hi = float(f.min()), float(f.max())
    if hi <= lo:
        raise RecordingError("force_n is constant; expected a recording with squeezes")
    active = np.flatnonzero(fw >= lo + 0.7 * (hi - lo))
    flex = [c - 1 for c in FLEXOR_CHANNELS]
    ext = [c - 1 for c in EXTENSOR_CHANNELS]
    act = xw[active]  # (n_active, win, 8)
    rms_flex = float(np.sqrt(np.mean(act[:, :, flex] ** 2)))
    rms_ext = float(np.sqrt(np.mean(act[:, :, ext] ** 2)))
    seg = act[:, :, flex] - act[:, :, flex].mean(axis=1, keepdims=True)
    spec = np.mean(np.abs(np.fft.rfft(seg, axis=1)) ** 2, axis=(0, 2))
    freqs = np.fft.rfftfreq(seg.shape[1], d=1.0 / fs_hz)
    cum = np.cumsum(spec) / spec.sum()
    samples = np.unique(idx[active].ravel())
    r = np.corrcoef(x[samples].T)
    adjacent = [abs(r[c, (c + 1) % 8]) for c in range(8)]
    return {
        "rest_std_lsb": float(xw[rest].std()),
        "active_rms_lsb": rms_flex,
        "median_frequency_hz": float(freqs[np.searchsorted(cum, 0.5)]),
        "adjacent_abs_r": float(np.nanmean(adjacent)),
        "saturated_fraction": saturated,
        "flexor_extensor_ratio": rms_flex / rms_ext if rms_ext > 0 else float("inf"),
    }


def recording_statistics(recording: object) -> dict[str, float]:
    """:func:`emg_statistics` of a :class:`~sim.recording.Recording` with measured force."""
    if recording.force_n is None:
        raise RecordingError(f"{recording.source}: no force column; active windows need the force")
    return emg_statistics(recording.emg, recording.force_n, recording.fs_hz)


def population_statistics(recordings: list) -> dict[str, dict[str, float]]:
    """Median, min and max over recordings of every statistic."""
    rows = [recording_statistics(r) for r in recordings]
    out = {}
    for key in STAT_KEYS:
        v = np.array([row[key] for row in rows])
        out[key] = {"median": float(np.median(v)), "min": float(v.min()),
                    "max": float(v.max())}
    return out
