"""What makes free-run force estimation hard in a recording: eight per-recording statistics.

The same definitions as the statistics of the real recordings in
``shared/REAL_RECORDINGS.md`` (so that a virtual population can be set beside them):
400 ms windows every 125 ms; the force of a window is its mean over the window's last
125 ms.

- ``squeezes``: rising crossings of 20 % of the session's largest window force;
- ``peak_cv``: coefficient of variation of the squeezes' peaks (normalized force);
- ``duty``: fraction of windows above 20 %;
- ``r2_lin_in`` / ``r2_lin_out``: a least-squares linear map from the MAV of every channel
  (plus an offset) to force, fitted on the first half of the windows and scored on the
  first / second half;
- ``drift``: MAV of channels 6-8 per unit force in the windows of the top 30 % of each
  half's force range, second half over first half;
- ``lag_ms``: the lag (in 125 ms steps, -1000..1000 ms) of force behind the channel 6-8 MAV
  envelope at maximum cross-correlation (the 400 ms window itself delays the envelope, so
  negative values are expected);
- ``nonlin``: R^2 gained by a quadratic over a linear fit of force on the channel 6-8 MAV.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from sim.recording import RecordingError

#: Names of the statistics :func:`recording_difficulty` returns, in order.
STATISTICS = ("squeezes", "peak_cv", "duty", "r2_lin_in", "r2_lin_out", "drift", "lag_ms",
              "nonlin")
WINDOW_S = 0.4
HOP_S = 0.125
SQUEEZE_THRESHOLD = 0.2
TOP_FRACTION = 0.3
MAX_LAG = 8
FLEXOR_CHANNELS = (5, 6, 7)  # 0-based: MYO channels 6-8


def _r2(y: np.ndarray, y_hat: np.ndarray) -> float:
    ss = float(np.sum((y - y.mean()) ** 2))
    return float(1.0 - np.sum((y - y_hat) ** 2) / ss) if ss > 0 else float("nan")


def _windows(emg: np.ndarray, force: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Channel MAV per 400 ms window, shape (n, n_channels), and force, shape (n,)."""
    w, h = int(WINDOW_S * fs_hz), int(HOP_S * fs_hz)
    ends = np.arange(w, emg.shape[0] + 1, h)
    csum = np.vstack([np.zeros((1, emg.shape[1])), np.cumsum(np.abs(emg), axis=0)])
    fsum = np.concatenate([[0.0], np.cumsum(force)])
    return (csum[ends] - csum[ends - w]) / w, (fsum[ends] - fsum[ends - h]) / h


def _gain(m: np.ndarray, y: np.ndarray) -> float:
    top = y >= y.min() + (1.0 - TOP_FRACTION) * (y.max() - y.min())
    return float(m[top].mean() / max(y[top].mean(), 1e-9))


def _lag_ms(m: np.ndarray, y: np.ndarray) -> float:
    n = m.size
    m = (m - m.mean()) / (m.std() or 1.0)
    y = (y - y.mean()) / (y.std() or 1.0)
    lags = np.arange(-MAX_LAG, MAX_LAG + 1)
    cc = [np.mean(m[max(0, -k):n - max(0, k)] * y[max(0, k):n - max(0, -k)]) for k in lags]
    return float(lags[int(np.argmax(cc))] * HOP_S * 1e3)


def _peaks(fn: np.ndarray) -> tuple[int, float]:
    above = fn > SQUEEZE_THRESHOLD
    starts = np.flatnonzero(np.diff(above.astype(int)) == 1)
    peaks = []
    for s in starts:
        rest = np.flatnonzero(~above[s + 1:])
        end = s + 1 + (rest[0] if rest.size else above.size - s - 1)
        peaks.append(fn[s:end].max())
    cv = float(np.std(peaks) / np.mean(peaks)) if peaks else float("nan")
    return len(starts), cv


def recording_difficulty(emg: np.ndarray, force_n: np.ndarray, fs_hz: float) -> dict[str, float]:
    """The statistics of one recording (see the module docstring).

    Parameters
    ----------
    emg : ndarray, shape (n_samples, n_channels)
        sEMG (any unit), at least 8 channels (channels 6-8 are the flexors).
    force_n : ndarray, shape (n_samples,)
        Measured force.
    fs_hz : float
        Sampling rate in hertz.

    Returns
    -------
    dict
        One float per name of :data:`STATISTICS`.

    Raises
    ------
    sim.recording.RecordingError
        Fewer than 8 channels, mismatched lengths, or fewer than 4 windows.
    """
    emg = np.asarray(emg, dtype=float)
    force_n = np.asarray(force_n, dtype=float)
    if emg.ndim != 2 or emg.shape[1] < 8 or force_n.shape != (emg.shape[0],):
        raise RecordingError(f"expected emg (n, >= 8) and force (n,), found {emg.shape} and "
                         f"{force_n.shape}")
    mav, y = _windows(emg, force_n, fs_hz)
    n = y.size
    if n < 4:
        raise RecordingError(f"expected at least 4 windows of {WINDOW_S} s, found {n}")
    half = n // 2
    squeezes, peak_cv = _peaks(y / max(float(y.max()), 1e-9))
    X = np.hstack([mav, np.ones((n, 1))])
    coef = np.linalg.lstsq(X[:half], y[:half], rcond=None)[0]
    flex = mav[:, list(FLEXOR_CHANNELS)].mean(axis=1)
    z = (flex - flex.mean()) / (flex.std() or 1.0)
    nonlin = _r2(y, np.polyval(np.polyfit(z, y, 2), z)) - _r2(y, np.polyval(np.polyfit(z, y, 1), z))
    return {
        "squeezes": float(squeezes),
        "peak_cv": peak_cv,
        "duty": float(np.mean(y / max(float(y.max()), 1e-9) > SQUEEZE_THRESHOLD)),
        "r2_lin_in": _r2(y[:half], X[:half] @ coef),
        "r2_lin_out": _r2(y[half:], X[half:] @ coef),
        "drift": _gain(flex[half:], y[half:]) / _gain(flex[:half], y[:half]),
        "lag_ms": _lag_ms(flex, y),
        "nonlin": float(nonlin),
    }


def summarize(rows: Sequence[dict[str, float]]) -> dict[str, dict[str, float]]:
    """Median, mean, min and max of each statistic over recordings (NaN ignored)."""
    out = {}
    for key in STATISTICS:
        v = np.array([r[key] for r in rows], dtype=float)
        out[key] = {"median": float(np.nanmedian(v)), "mean": float(np.nanmean(v)),
                    "min": float(np.nanmin(v)), "max": float(np.nanmax(v))}
    return out


# ------------------------------------------------------------------ inner -> outer
#: Statistics of choosing an estimator per person on the identification half (see
#: :func:`inner_outer`): per recording, then summarized over recordings by
#: :func:`summarize_inner_outer`.
INNER_OUTER_STATISTICS = ("spearman", "regret", "gain")


def inner_outer(inner: Mapping[str, float | None], outer: Mapping[str, float | None], *,
                reference: str = "mlp") -> dict[str, float | str]:
    """How well the inner split of one recording's identification half guides the choice.

    The *inner* figure of an estimator is its R^2 when the identification half is split in
    time (its first half fits, its second half validates); the *outer* figure the usual one
    (fit on the identification half, score on the evaluation half). Choosing per person
    means picking the estimator with the best inner figure.

    Parameters
    ----------
    inner, outer : mapping
        Estimator name -> R^2 (free_run). Estimators whose inner or outer figure is missing
        or not finite (an unstable model) take no part.
    reference : str
        The estimator the pick is compared with (the one a prosthetist would use anyway).

    Returns
    -------
    dict
        ``spearman``: rank correlation of inner and outer over the estimators; ``pick``: the
        estimator with the best inner figure; ``pick_outer``: its outer figure; ``best_outer``;
        ``regret = best_outer - pick_outer``; ``gain = pick_outer - outer[reference]``
        (NaN without the reference).

    Raises
    ------
    ValueError
        Fewer than 3 estimators with both figures.
    """
    from scipy.stats import spearmanr

    names = [n for n in inner if n in outer and inner[n] is not None and outer[n] is not None
             and np.isfinite(inner[n]) and np.isfinite(outer[n])]
    if len(names) < 3:
        raise ValueError(f"inner_outer: expected at least 3 estimators with both figures, "
                         f"found {names}")
    i = np.array([inner[n] for n in names], dtype=float)
    o = np.array([outer[n] for n in names], dtype=float)
    pick = names[int(np.argmax(i))]
    ref = outer.get(reference)
    return {"spearman": float(spearmanr(i, o).statistic), "pick": pick,
            "pick_outer": float(outer[pick]), "best_outer": float(o.max()),
            "regret": float(o.max() - outer[pick]),
            "gain": float(outer[pick] - ref) if ref is not None else float("nan")}


def summarize_inner_outer(rows: Sequence[Mapping[str, float]]) -> dict[str, float]:
    """The summary of issue 28 over recordings (rows of :func:`inner_outer`).

    Returns
    -------
    dict
        ``spearman_median``, ``spearman_min``, ``spearman_max``, ``regret_mean``,
        ``gain_mean`` and ``gain_min`` (the pick's worst loss against the reference).
    """
    rho = np.array([r["spearman"] for r in rows], dtype=float)
    regret = np.array([r["regret"] for r in rows], dtype=float)
    gain = np.array([r["gain"] for r in rows], dtype=float)
    return {"spearman_median": float(np.nanmedian(rho)), "spearman_min": float(np.nanmin(rho)),
            "spearman_max": float(np.nanmax(rho)), "regret_mean": float(np.nanmean(regret)),
            "gain_mean": float(np.nanmean(gain)), "gain_min": float(np.nanmin(gain))}
