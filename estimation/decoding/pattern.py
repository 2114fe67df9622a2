"""Pattern recognition over all the armband's channels: rest, close or open, at a speed.

An armband has no dedicated sites: the channels over the extensors co-contract during a
squeeze (on the paper's recordings the flexor/extensor RMS ratio of squeezes ranges
0.36-1.19, so some people's squeezes look extensor-dominant). Armband-based hands decode
the direction from the pattern over every channel instead:

- a linear discriminant (scikit-learn's ``LinearDiscriminantAnalysis``, ``solver="lsqr"``
  with ``shrinkage``) on ``log(MAV + 1)`` of every channel decides rest, close or open per
  window (``argmax`` of ``coef_ z + intercept_``);
- the speed comes from the amplitude, the mean MAV over all channels ``m``, as clinicians
  set a gain: ``level = clip((m - rest_) / (max - rest_), 0, 1)`` with the decided
  class's own largest contraction ``max`` (95th percentile of ``m`` over its windows:
  ``close_max_`` or ``open_max_``) and ``rest_`` the median of ``m`` at rest;
- a window decided close or open is rest unless its level reaches ``on_fraction``; once
  on, the same direction stays on until its level falls below ``off_fraction``
  (hysteresis);
- **a reversal passes through rest**: a window of the other direction than the one on is
  rest (the motor stops), and only the next such window may turn it on, at
  ``on_fraction``. One window that looks like an opening in the middle of a squeeze
  (co-contraction varies from squeeze to squeeze) then stops the hand instead of opening
  it; an intended reversal costs one window (125 ms).

**Both sites active.** There is no site to disagree: the classifier decides one class per
window. A co-contraction is a pattern like any other: a squeeze with strong extensor
co-contraction is still ``close`` if the calibration's squeezes looked like it, and an
opening contraction is ``open`` because its pattern differs, not because the extensor
channels are larger. Nothing in the decoder switches function on co-contraction.
"""

from __future__ import annotations

import numpy as np
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis
from sklearn.utils.validation import check_is_fitted

from estimation.decoding.base import OpenCloseDecoder
from estimation.decoding.windows import (
    CLOSE,
    LABELS,
    OPEN,
    REST,
    check_fractions,
    check_labels,
    class_levels,
    require_classes,
)


class PatternDecoder(OpenCloseDecoder):
    """LDA over every channel for the direction, the mean MAV for the speed (module notes).

    Parameters
    ----------
    on_fraction : float
        A close or open window turns on at this level (fraction of the class's largest
        contraction over rest).
    off_fraction : float
        An active direction turns off below this level (``<= on_fraction``).
    shrinkage : "auto", float or None
        The LDA's covariance shrinkage (scikit-learn's ``shrinkage``).

    Attributes
    ----------
    lda_ : LinearDiscriminantAnalysis
        Fitted on ``log(MAV + 1)`` of every channel, classes ``[0, 1, 2]``.
    coef_ : ndarray, shape (3, n_channels)
        The discriminant's weights (``lda_.coef_``): one row per class.
    intercept_ : ndarray, shape (3,)
        Its intercepts.
    rest_ : float
        Median of the mean MAV over all channels at rest (LSB).
    close_max_, open_max_ : float
        95th percentile of the mean MAV over the close and over the open windows (LSB).
    gain_ : ndarray, shape (2,)
        ``1 / (close_max_ - rest_)`` and ``1 / (open_max_ - rest_)``: level per LSB.
    n_features_in_ : int
        Channels per window.
    classes_ : ndarray
        ``[0, 1, 2]`` (rest, close, open).
    """

    name = "pattern"

    def __init__(self, on_fraction: float = 0.15, off_fraction: float = 0.08,
                 shrinkage: str | float | None = "auto") -> None:
        self.on_fraction = on_fraction
        self.off_fraction = off_fraction
        self.shrinkage = shrinkage

    def fit(self, X: np.ndarray, y: np.ndarray) -> PatternDecoder:
        """Fit the discriminant and set the rest level and each class's largest contraction.

        Parameters
        ----------
        X : ndarray, shape (n_windows, n_channels)
            MAV of every channel per window (LSB).
        y : ndarray of int, shape (n_windows,)
            0 rest, 1 close, 2 open (:func:`~estimation.decoding.windows.decoder_windows`).

        Returns
        -------
        self

        Raises
        ------
        NoOpenContractionsError
            No open windows.
        DecoderCalibrationError
            No rest or close windows, or a class whose amplitude never rises above rest.
        EstimationInputError
            Malformed ``X``, ``y`` or thresholds.
        """
        X = self._check_X(X, fitted=False)
        y = check_labels(y, X.shape[0])
        check_fractions(self.name, self.on_fraction, self.off_fraction)
        require_classes(self.name, y)
        n = X.shape[1]
        m = X.mean(axis=1)
        what = f"the mean of channels 1-{n}"
        rest, close_max = class_levels(self.name, f"{what} in squeezes", m, y, CLOSE)
        _, open_max = class_levels(self.name, f"{what} in open contractions", m, y, OPEN)
        lda = LinearDiscriminantAnalysis(solver="lsqr", shrinkage=self.shrinkage)
        lda.fit(np.log1p(X), y)
        self.lda_ = lda
        self.coef_ = np.array(lda.coef_, dtype=np.float64)
        self.intercept_ = np.array(lda.intercept_, dtype=np.float64)
        self.rest_, self.close_max_, self.open_max_ = rest, close_max, open_max
        self.gain_ = 1.0 / (np.array([close_max, open_max]) - rest)
        self.n_features_in_ = n
        self.classes_ = np.array(LABELS)
        return self

    def class_scores(self, X: np.ndarray) -> np.ndarray:
        """Discriminant scores ``log(MAV + 1) coef_^T + intercept_``, shape (n_windows, 3)."""
        check_is_fitted(self)
        return np.log1p(np.asarray(X, dtype=np.float64)) @ self.coef_.T + self.intercept_

    def window_levels(self, X: np.ndarray) -> np.ndarray:
        """Per window: the decided class and its amplitude level, shape (n_windows, 2)."""
        cls = np.argmax(self.class_scores(X), axis=1)
        m = np.asarray(X, dtype=np.float64).mean(axis=1)
        gain = np.where(cls == OPEN, self.gain_[1], self.gain_[0])
        level = np.clip((m - self.rest_) * gain, 0.0, 1.0)
        return np.column_stack([cls.astype(np.float64), np.where(cls == REST, 0.0, level)])

    def initial_state(self) -> tuple[int]:
        """``(label on,)``: rest."""
        return (REST,)

    def update(self, state: tuple[int], levels: np.ndarray
               ) -> tuple[tuple[float, float], tuple[int]]:
        """One window: the class's direction if its level passes the threshold (module notes)."""
        cls, level = int(levels[0]), float(levels[1])
        if cls != REST and state[0] not in (REST, cls):  # a reversal passes through rest
            return (0.0, 0.0), (REST,)
        threshold = float(self.off_fraction if state[0] == cls else self.on_fraction)
        if cls == REST or level <= 0.0 or level < threshold:
            return (0.0, 0.0), (REST,)
        if cls == CLOSE:
            return (level, 0.0), (CLOSE,)
        return (0.0, level), (OPEN,)

    def state_label(self, state: tuple[int]) -> int:
        """The label on."""
        return int(state[0])
