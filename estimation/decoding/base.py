"""The base of the open/close decoders: ``decode``, ``predict`` and the stream.

A decoder reads the MAV of every armband channel per feature window (the paper's 400 ms
every 125 ms) and returns, per window, ``(close_level, open_level)``: each 0..1 (the
proportional speed), at most one of them nonzero. It decodes in sequence: a contraction
turns on above ``on_fraction`` and stays on until it falls below ``off_fraction``
(hysteresis), so the same window can decode differently after a contraction than after
rest. :meth:`OpenCloseDecoder.decode` and :meth:`DecoderStream.step` run the same state
machine on the same per-window levels (both start at rest).
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.validation import check_is_fitted

from estimation.decoding.windows import decoded_labels
from estimation.errors import EstimationInputError, check_features


class DecoderStream:
    """One decoder's state machine, window by window.

    ``step(mav_row)`` gives what :meth:`OpenCloseDecoder.decode` gives for that row after
    the rows stepped since the last ``reset()`` (a new stream starts at rest).

    Parameters
    ----------
    decoder : OpenCloseDecoder
        Fitted.
    """

    def __init__(self, decoder: OpenCloseDecoder) -> None:
        check_is_fitted(decoder)
        self.decoder = decoder
        self.n_inputs = int(decoder.n_features_in_)
        self.reset()

    def reset(self) -> None:
        """Back to rest: no contraction on."""
        self.state = self.decoder.initial_state()

    def step(self, mav_row: np.ndarray) -> tuple[float, float]:
        """One window.

        Parameters
        ----------
        mav_row : ndarray, shape (n_channels,)
            The window's MAV of every channel.

        Returns
        -------
        close_level, open_level : float
            Each 0..1, at most one nonzero.
        """
        row = np.asarray(mav_row, dtype=np.float64).reshape(1, self.n_inputs)
        levels = self.decoder.window_levels(row)[0]
        out, self.state = self.decoder.update(self.state, levels)
        return out

    def label(self) -> int:
        """The label of the last step's output (0 rest, 1 close, 2 open)."""
        return self.decoder.state_label(self.state)


class OpenCloseDecoder(ClassifierMixin, BaseEstimator):
    """Base of the decoders: checks, ``decode``, ``predict`` and ``stream`` (module notes).

    A subclass implements ``fit``, :meth:`window_levels` (vectorized, per window),
    :meth:`initial_state`, :meth:`update` (one window's state machine) and
    :meth:`state_label`.
    """

    #: The decoder's registered name, for messages.
    name = "decoder"

    def _check_X(self, X: np.ndarray, *, fitted: bool) -> np.ndarray:
        n = int(self.n_features_in_) if fitted else None
        X = check_features(X, name="X", n_inputs=n, who=self.name)
        if np.any(X < 0):
            row, col = np.argwhere(X < 0)[0]
            raise EstimationInputError(f"{self.name}: X holds MAV values, expected >= 0; "
                                       f"found {X[row, col]!r} at row {row}, column {col}")
        return X

    def window_levels(self, X: np.ndarray) -> np.ndarray:
        """What the state machine reads per window (vectorized), shape (n_windows, k)."""
        raise NotImplementedError

    def initial_state(self) -> tuple:
        """The state at rest."""
        raise NotImplementedError

    def update(self, state: tuple, levels: np.ndarray
               ) -> tuple[tuple[float, float], tuple]:
        """One window: ``((close_level, open_level), new_state)``."""
        raise NotImplementedError

    def state_label(self, state: tuple) -> int:
        """The label (0 rest, 1 close, 2 open) a state outputs."""
        raise NotImplementedError

    def stream(self) -> DecoderStream:
        """A new :class:`DecoderStream` at rest."""
        return DecoderStream(self)

    def decode(self, X: np.ndarray) -> np.ndarray:
        """Close and open levels of a sequence of windows, from rest.

        Parameters
        ----------
        X : ndarray, shape (n_windows, n_channels)
            MAV of every channel per window, in time order.

        Returns
        -------
        ndarray, shape (n_windows, 2)
            ``[close_level, open_level]`` per window, each 0..1, at most one nonzero.
        """
        check_is_fitted(self)
        X = self._check_X(X, fitted=True)
        levels = self.window_levels(X)
        out = np.zeros((X.shape[0], 2))
        state = self.initial_state()
        for i in range(X.shape[0]):
            out[i], state = self.update(state, levels[i])
        return out

    def predict(self, X: np.ndarray) -> np.ndarray:
        """Labels of a sequence of windows (0 rest, 1 close, 2 open), as :meth:`decode`.

        Returns
        -------
        ndarray of int, shape (n_windows,)
        """
        return decoded_labels(self.decode(X))
