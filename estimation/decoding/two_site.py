"""The clinical two-site decoder: a flexor site closes, an extensor site opens.

A myoelectric hand reads two electrode sites, one over the finger flexors and one over
the extensors. On an armband each site is a group of channels (default: the paper's
table, flexors on channels 6-8 and extensors on 3-5, 1-based); a site's amplitude is the
mean MAV of its channels. A clinician sets, per site, the rest level and the largest
contraction, and the thresholds and gains from them:

- rest level ``rest_``: the site's median at rest;
- largest contraction ``max_``: the 95th percentile of the site over its own class's
  windows (the flexor site over the squeezes, the extensor site over the open
  contractions);
- normalized level ``a = clip((site - rest_) / (max_ - rest_), 0, 1)``: the proportional
  speed (gain ``1 / (max_ - rest_)``);
- a site turns on when ``a >= on_fraction`` (of the largest contraction, over rest) and
  stays on until ``a < off_fraction`` (hysteresis).

When both sites are on (a co-contraction: on an armband the extensor channels co-contract
during every squeeze), ``conflict`` decides:

``"difference"``
    the clinical difference rule: the site with the larger level wins, at the speed of the
    difference of the two levels (thresholds first: a site that is off counts 0);
``"first"``
    first come: the site that turned on first keeps control until it falls below
    ``off_fraction``; if both turn on in the same window the larger level wins (close on a
    tie). The other site takes over if it is still on when the first one lets go.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from sklearn.utils.validation import check_is_fitted

from estimation.decoding.base import OpenCloseDecoder
from estimation.decoding.windows import (
    CLOSE,
    LABELS,
    OPEN,
    REST,
    channel_text,
    check_fractions,
    check_labels,
    class_levels,
    require_classes,
)
from estimation.errors import EstimationInputError

#: The conflict rules when both sites are on (module notes).
CONFLICT_RULES = ("difference", "first")


class TwoSiteDecoder(OpenCloseDecoder):
    """Per-site amplitudes, thresholds and gains set from a calibration (module notes).

    Parameters
    ----------
    flexor_channels : sequence of int
        1-based channels of the flexor (close) site.
    extensor_channels : sequence of int
        1-based channels of the extensor (open) site.
    on_fraction : float
        A site turns on at this level, a fraction of its largest contraction over rest.
    off_fraction : float
        An active site turns off below this level (``<= on_fraction``).
    conflict : {"difference", "first"}
        What wins when both sites are on.

    Attributes
    ----------
    rest_ : ndarray, shape (2,)
        Rest level of the flexor and extensor sites (mean MAV of their channels, LSB).
    max_ : ndarray, shape (2,)
        Largest contraction of each site (95th percentile over its own class's windows).
    gain_ : ndarray, shape (2,)
        ``1 / (max_ - rest_)``: level per LSB above rest.
    flexor_index_, extensor_index_ : ndarray of int
        0-based columns of each site.
    n_features_in_ : int
        Channels per window.
    classes_ : ndarray
        ``[0, 1, 2]`` (rest, close, open).
    """

    name = "two_site"

    def __init__(self, flexor_channels: Sequence[int] = (6, 7, 8),
                 extensor_channels: Sequence[int] = (3, 4, 5), on_fraction: float = 0.15,
                 off_fraction: float = 0.08, conflict: str = "difference") -> None:
        self.flexor_channels = flexor_channels
        self.extensor_channels = extensor_channels
        self.on_fraction = on_fraction
        self.off_fraction = off_fraction
        self.conflict = conflict

    def _site_index(self, channels: Sequence[int], n_channels: int, what: str) -> np.ndarray:
        idx = np.asarray(channels, dtype=np.intp).ravel()
        if idx.size == 0 or np.any(idx < 1) or np.any(idx > n_channels) or \
                np.unique(idx).size != idx.size:
            raise EstimationInputError(
                f"{self.name}: {what}_channels: expected distinct 1-based channels in "
                f"1..{n_channels}, found {[int(c) for c in np.asarray(channels).ravel()]}")
        return idx - 1

    def fit(self, X: np.ndarray, y: np.ndarray) -> TwoSiteDecoder:
        """Set each site's rest level, largest contraction and gain from labelled windows.

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
            No rest or close windows, or a site that never rises above its rest level
            (the message names the site and its channels).
        EstimationInputError
            Malformed ``X``, ``y``, channels, thresholds or conflict rule.
        """
        X = self._check_X(X, fitted=False)
        y = check_labels(y, X.shape[0])
        check_fractions(self.name, self.on_fraction, self.off_fraction)
        if self.conflict not in CONFLICT_RULES:
            raise EstimationInputError(f"{self.name}: conflict must be one of "
                                       f"{CONFLICT_RULES}, found {self.conflict!r}")
        n = X.shape[1]
        flexor = self._site_index(self.flexor_channels, n, "flexor")
        extensor = self._site_index(self.extensor_channels, n, "extensor")
        require_classes(self.name, y)
        rest, largest = [], []
        for idx, channels, what, label in (
                (flexor, self.flexor_channels, "flexor", CLOSE),
                (extensor, self.extensor_channels, "extensor", OPEN)):
            site = X[:, idx].mean(axis=1)
            r, m = class_levels(self.name, f"the {what} site ({channel_text(channels)})",
                                site, y, label)
            rest.append(r)
            largest.append(m)
        self.flexor_index_, self.extensor_index_ = flexor, extensor
        self.rest_ = np.array(rest)
        self.max_ = np.array(largest)
        self.gain_ = 1.0 / (self.max_ - self.rest_)
        self.n_features_in_ = n
        self.classes_ = np.array(LABELS)
        return self

    def site_amplitudes(self, X: np.ndarray) -> np.ndarray:
        """Mean MAV of each site's channels, shape (n_windows, 2): flexor, extensor (LSB)."""
        check_is_fitted(self)
        X = np.asarray(X, dtype=np.float64)
        return np.column_stack([X[:, self.flexor_index_].mean(axis=1),
                                X[:, self.extensor_index_].mean(axis=1)])

    def window_levels(self, X: np.ndarray) -> np.ndarray:
        """Normalized levels ``a`` of the flexor and extensor sites, shape (n_windows, 2)."""
        return np.clip((self.site_amplitudes(X) - self.rest_) * self.gain_, 0.0, 1.0)

    def initial_state(self) -> tuple[bool, bool, int]:
        """``(flexor on, extensor on, label in control)``: both off, rest."""
        return (False, False, REST)

    def update(self, state: tuple[bool, bool, int], levels: np.ndarray
               ) -> tuple[tuple[float, float], tuple[bool, bool, int]]:
        """One window's thresholds, hysteresis and conflict rule (module notes)."""
        was_f, was_e, owner = state
        a_f, a_e = float(levels[0]), float(levels[1])
        on, off = float(self.on_fraction), float(self.off_fraction)
        act_f = a_f > 0.0 and a_f >= (off if was_f else on)
        act_e = a_e > 0.0 and a_e >= (off if was_e else on)
        if self.conflict == "difference":
            d = (a_f if act_f else 0.0) - (a_e if act_e else 0.0)
            if d > 0.0:
                return (d, 0.0), (act_f, act_e, CLOSE)
            if d < 0.0:
                return (0.0, -d), (act_f, act_e, OPEN)
            return (0.0, 0.0), (act_f, act_e, REST)
        if (owner == CLOSE and not act_f) or (owner == OPEN and not act_e):
            owner = REST
        if owner == REST:
            if act_f and act_e:
                owner = CLOSE if a_f >= a_e else OPEN
            elif act_f:
                owner = CLOSE
            elif act_e:
                owner = OPEN
        if owner == CLOSE:
            return (a_f, 0.0), (act_f, act_e, owner)
        if owner == OPEN:
            return (0.0, a_e), (act_f, act_e, owner)
        return (0.0, 0.0), (act_f, act_e, REST)

    def state_label(self, state: tuple[bool, bool, int]) -> int:
        """The label in control."""
        return int(state[2])
