"""The rest threshold of a myoelectric hand: closed by a contraction, opened by relaxing.

A myoelectric prosthesis acts only on signals above a threshold set over the user's
resting signal, so that the hand does not move while the user rests; clinicians set it
from the signal at rest. A force estimate does not fall to zero at rest either: the
electrodes' noise floor drifts and the estimators read it as force (the free-run
estimate of a population subject at sustained rest has a 95th percentile of 1-10 N of
hand force for the MLP). Without a threshold the hand never lets go of what it holds.

:class:`RestGate` is that threshold with hysteresis, on the estimate (N, the user's
force scale):

* while open, an estimate at or above ``on_n`` closes it (the user contracted);
* while closed, the estimate passes through unchanged until it falls below ``off_n``
  (the user relaxed), which opens it;
* an open gate outputs 0 (the hand opens).

:func:`rest_thresholds` sets them from a calibration session: ``on_n`` is the 95th
percentile of the estimate over the windows of *sustained* rest (the measured force
below 5 % of the session's largest for 0.5 s on either side, away from the squeezes'
onsets and the windows that straddle them), ``off_n`` its median. At rest the hand
therefore closes by itself in about 5 % of the windows and opens again as soon as the
estimate returns to its median.
"""

from __future__ import annotations

import numpy as np

REST_FRACTION = 0.05
"""Measured force below this fraction of the session's largest counts as rest."""
REST_MARGIN_S = 0.5
"""Rest must last this long on either side of a window to count as sustained, s."""
MIN_REST_WINDOWS = 10
"""Fewer sustained-rest windows than this: no threshold (the gate passes everything)."""


def rest_thresholds(estimate_n: np.ndarray, force_n: np.ndarray, dt_s: float
                    ) -> tuple[float, float]:
    """The gate's ``(on_n, off_n)`` from a session's estimates and measured force (module notes).

    Parameters
    ----------
    estimate_n, force_n : ndarray, shape (n_windows,)
        The estimator's output over the session and the measured force, N.
    dt_s : float
        Window period, s.

    Returns
    -------
    on_n, off_n : float
        The 95th percentile and the median of the estimate at sustained rest, N;
        ``(0.0, 0.0)`` (no threshold) with fewer than :data:`MIN_REST_WINDOWS`
        such windows or no positive force.
    """
    estimate_n = np.asarray(estimate_n, dtype=float)
    force_n = np.asarray(force_n, dtype=float)
    peak = float(np.max(force_n)) if force_n.size else 0.0
    if not peak > 0:
        return 0.0, 0.0
    low = force_n < REST_FRACTION * peak
    margin = int(round(REST_MARGIN_S / dt_s))
    padded = np.concatenate([np.zeros(margin, bool), low, np.zeros(margin, bool)])
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * margin + 1)
    sustained = windows.all(axis=1) & np.isfinite(estimate_n)
    if int(sustained.sum()) < MIN_REST_WINDOWS:
        return 0.0, 0.0
    rest = estimate_n[sustained]
    on_n, off_n = np.percentile(rest, [95.0, 50.0])
    return float(max(on_n, 0.0)), float(max(min(off_n, on_n), 0.0))


class RestGate:
    """The rest threshold with hysteresis (module notes).

    Parameters
    ----------
    on_n, off_n : float
        Close above ``on_n``, open below ``off_n`` (``off_n <= on_n``), N. With
        ``on_n <= 0`` the gate passes every estimate (no threshold).
    """

    def __init__(self, on_n: float = 0.0, off_n: float = 0.0) -> None:
        self.on_n = float(on_n)
        self.off_n = float(min(off_n, on_n))
        self.closed = False

    def reset(self) -> None:
        """Open, as at rest."""
        self.closed = False

    def step(self, estimate_n: float) -> float:
        """The estimate the hand acts on: ``estimate_n`` while closed, 0 while open, N."""
        if self.on_n <= 0.0:
            return estimate_n
        if self.closed:
            if estimate_n < self.off_n:
                self.closed = False
        elif estimate_n >= self.on_n:
            self.closed = True
        return estimate_n if self.closed else 0.0

    def run(self, estimates_n: np.ndarray) -> np.ndarray:
        """:meth:`step` over a sequence (from the gate's current state), N."""
        return np.array([self.step(float(v)) for v in np.asarray(estimates_n, dtype=float)])
