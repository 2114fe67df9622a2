"""What the prosthesis makes of a person's sEMG as it arrives: the hand's force reference.

Every trial turns samples into the reference the same way, whoever sends them (a virtual
subject, a recording, an LSL stream)::

    samples --FeatureWindow (MAV/RMS/WL of the calibration's channels, 400 ms every 125 ms)-->
        the fitted estimator's stream (one_step: the measured force at the previous
        window's end) --rest gate--> user newtons --force mapping--> hand newtons,
        clipped to 0..1.2 x the hand force at the user's MVC

and holds each window's value until the next window (0 before the first). A calibration
that fitted an open/close decoder (:mod:`estimation.decoding`) also has every window's MAV
of all the armband's channels decoded into the close and open levels
(:class:`~controllers.paradigms.Decoded`, held likewise; relaxed before the first). The force
mapping is :mod:`scenarios.runners.episode`'s: ``hand_force_at_mvc_n / mvc_cal_n``. The
oracle (a calibration without a pipeline) is the user's true grip at each window's end,
through the same mapping.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.paradigms import RELAXED, Decoded
from estimation.feature_window import FeatureWindow
from scenarios.runners.dispatch import UnsupportedScenarioError

WINDOW_MS = 400.0
"""The paper's feature window, ms (the default of ``estimator.window_ms``)."""
STEP_MS = 125.0
"""The paper's window increment, ms (the default of ``estimator.step_ms``)."""
CEILING = 1.2
"""References are clipped to this many times the hand force at the user's MVC."""
NOT_OPENING = 0.05
"""The open intent below which a person is not opening (the decoder labels' rest edge)."""

@dataclass(frozen=True)
class HandReference:
    """How an estimate becomes the hand's reference: rest gate, force mapping, paradigm.

    Attributes
    ----------
    to_hand : float or None
        Hand newtons per estimated user newton (``None``: 1).
    reference_max_n : float or None
        The reference's ceiling, N (``None``: none).
    rest_on_n, rest_off_n : float
        The rest gate's edges on the estimate, N (:mod:`estimation.rest_gate`; 0: none).
    paradigm : str
        How the reference follows the gated, mapped estimate (:mod:`controllers.paradigms`).
    """

    to_hand: float | None = None
    reference_max_n: float | None = None
    rest_on_n: float = 0.0
    rest_off_n: float = 0.0
    paradigm: str = "force"

    @classmethod
    def of_calibration(cls, calibration: Any, hand_force_at_mvc_n: float,
                       paradigm: str = "force") -> HandReference:
        """The chain every trial runs for ``calibration`` (its ``mvc_cal_n`` and rest
        thresholds), mapped so its strongest squeeze asks ``hand_force_at_mvc_n``."""
        return cls(hand_force_at_mvc_n / calibration.mvc_cal_n,
                   CEILING * hand_force_at_mvc_n, calibration.rest_on_n,
                   calibration.rest_off_n, paradigm)

    def check(self) -> HandReference:
        """``self``; ValueError naming the rest thresholds when they are not
        ``0 <= off <= on`` and finite."""
        on, off = self.rest_on_n, self.rest_off_n
        if not (math.isfinite(on) and math.isfinite(off) and 0.0 <= off <= on):
            raise ValueError(f"rest threshold: expected 0 <= off <= on (finite, N), found on "
                             f"{on!r}, off {off!r}")
        return self


#: ``forces() -> (true grip N, measured force N)`` of every sample pushed so far.
Forces = Callable[[], tuple[np.ndarray, np.ndarray | None]]


class SemgReference:
    """The hand reference from sEMG samples, window by window (module notes).

    Parameters
    ----------
    calibration : scenarios.runners.calibration.Calibration
        The fitted estimator (``pipeline``; ``None`` for the oracle), its mode, the
        calibration's largest force and rest thresholds.
    fs_hz : float
        Sampling rate of the samples, Hz.
    channel_index : sequence of int
        Zero-based columns of the samples the estimator was fitted on.
    window_ms, step_ms : float
        The feature window and its increment, ms.
    hand_force_at_mvc_n : float
        Hand force commanded at the calibration's strongest squeeze, N.
    integer : bool
        The samples are int8 counts (exact integer window sums).
    forces : callable, optional
        The true and measured force of every sample so far (``Forces``): needed by
        the oracle and by ``one_step``.

    Attributes
    ----------
    reference_n : float
        The latest window's value (held until the next), N.
    window_t_s, window_values_n : list of float
        Each window's end (its last sample's time from the first sample, s) and value, N.
    window_end : list of int
        Each window's last sample.
    decoded : Decoded or None
        The latest window's open and close signals (held until the next); ``None``
        without a decoder in the calibration.
    window_decoded : list of (float, float)
        Each window's close and open levels (empty without a decoder).
    timings : dict
        Wall time in the features and in the estimator, s.

    Raises
    ------
    UnsupportedScenarioError
        The oracle or a ``one_step`` estimator without ``forces``.
    """

    def __init__(self, calibration: Any, *, fs_hz: float, channel_index: Sequence[int],
                 window_ms: float = WINDOW_MS, step_ms: float = STEP_MS,
                 hand_force_at_mvc_n: float, integer: bool = True,
                 forces: Forces | None = None) -> None:
        self.oracle = calibration.pipeline is None
        self.one_step = calibration.mode == "one_step"
        if (self.oracle or self.one_step) and forces is None:
            what = "the oracle" if self.oracle else f"{calibration.name} in one_step"
            raise UnsupportedScenarioError(
                f"{what} needs the user's force at every window, which these samples do not "
                "carry; expected a fitted estimator in free_run")
        self.calibration = calibration
        self.fs_hz = float(fs_hz)
        self.window = FeatureWindow(fs_hz, channel_index, window_ms=window_ms,
                                    step_ms=step_ms, integer=integer)
        self.hop = self.window.step
        mapping = HandReference.of_calibration(calibration, hand_force_at_mvc_n)
        self.to_hand, self.ceiling = mapping.to_hand, mapping.reference_max_n
        self._forces = forces
        self.stream = None if self.oracle else calibration.pipeline.streaming(calibration.mode)
        self.decoder = getattr(calibration, "decoder", None)
        self.hand_force_at_mvc_n = float(hand_force_at_mvc_n)
        self.decoder_window = self.decoder_stream = None
        if self.decoder is not None:
            self.decoder_window = FeatureWindow(
                fs_hz, range(int(self.decoder.n_features_in_)), window_ms=window_ms,
                step_ms=step_ms, features=("mav",), integer=integer)
            self.decoder_stream = self.decoder.stream()
        self.reset()

    def reset(self) -> None:
        """Before a trial: no sample, the estimator and the rest gate at rest."""
        self.window.reset()
        if self.stream is not None:
            self.stream.reset()
        if self.decoder_window is not None:
            self.decoder_window.reset()
            self.decoder_stream.reset()
        self.decoded: Decoded | None = None if self.decoder is None else RELAXED
        self.window_decoded: list[tuple[float, float]] = []
        self.gate = self.calibration.rest_gate()
        self.base = 0  # index of the window's first sample since the trial began
        self.reference_n = 0.0
        self.window_t_s: list[float] = []
        self.window_end: list[int] = []
        self.window_values_n: list[float] = []
        self.timings = {"t_features_s": 0.0, "t_estimator_s": 0.0}

    def restart_windows(self, at_sample: int) -> None:
        """Windows start again with sample ``at_sample`` (after a gap); the estimator keeps
        its state and the reference holds until the next window."""
        self.window.reset()
        if self.decoder_window is not None:
            self.decoder_window.reset()
        self.base = int(at_sample)

    def push(self, samples: np.ndarray) -> int:
        """Take the next samples; the windows they complete update the reference.

        Parameters
        ----------
        samples : ndarray, shape (m, n_channels)
            Every channel of the next ``m`` samples.

        Returns
        -------
        int
            Windows completed.
        """
        t0 = time.perf_counter()
        rows, ends = self.window.push(samples)
        if self.decoder_window is not None:
            self._decode(self.decoder_window.push(samples)[0])
        t1 = time.perf_counter()
        self.timings["t_features_s"] += t1 - t0
        if not ends.size:
            return 0
        grip_n = force_n = None
        if self.oracle or self.one_step:
            grip_n, force_n = self._forces()
        to_hand, ceiling, gate, stream = self.to_hand, self.ceiling, self.gate, self.stream
        for row, end in zip(rows, (ends + self.base).tolist(), strict=True):
            if stream is None:
                estimate = grip_n[end] * to_hand
            else:
                y_prev = None
                if self.one_step:
                    y_prev = float(force_n[end - self.hop]) if self.window_end else 0.0
                estimate = gate.step(stream.step(row, y_prev)) * to_hand
            value = 0.0 if estimate < 0.0 else ceiling if estimate > ceiling else float(estimate)
            if value == value:  # a NaN estimate leaves the reference where it was
                self.reference_n = value
            self.window_t_s.append(end / self.fs_hz)
            self.window_end.append(end)
            self.window_values_n.append(self.reference_n)
        self.timings["t_estimator_s"] += time.perf_counter() - t1
        return int(ends.size)

    def decoder_counts(self, open_intent: np.ndarray | None) -> dict[str, int | None]:
        """The windows decoded so far, and those decoded open while the person was not
        opening.

        Parameters
        ----------
        open_intent : ndarray, shape (n_samples,), or None
            The person's open intent at every sample since the reset (a virtual person's, or a
            recording's label); ``None``: unlabelled (a live person's).

        Returns
        -------
        dict
            With a decoder: ``decoder_windows`` and ``unrequested_opens`` (windows decoded
            open while ``open_intent`` at their last sample was below :data:`NOT_OPENING`;
            ``None`` when unlabelled). Empty without a decoder.
        """
        if self.decoder is None:
            return {}
        ends = np.asarray(self.window_end, dtype=int)
        if open_intent is None:
            return {"decoder_windows": int(ends.size), "unrequested_opens": None}
        opens = np.array([o > 0.0 for _, o in self.window_decoded], dtype=bool)
        asked = open_intent[np.minimum(ends, open_intent.size - 1)] >= NOT_OPENING
        return {"decoder_windows": int(ends.size),
                "unrequested_opens": int(np.sum(opens & ~asked))}

    def _decode(self, rows: np.ndarray) -> None:
        """Decode the MAV rows of the windows just completed (they end where the
        estimator's windows end: the same window, increment and samples)."""
        step, grip_at_full = self.decoder_stream.step, self.hand_force_at_mvc_n
        for row in rows:
            close, open_ = step(row)
            self.window_decoded.append((close, open_))
            self.decoded = Decoded(close, open_, close * grip_at_full)
