"""How often a decoder does what nobody asked for.

The acceptance measure of issue 36: during squeezes with no open intent, an open issued by
the decoder opens the hand on the object (at most 1 % of the windows, for every subject);
at rest, a close issued by the decoder closes the hand on nothing.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from estimation.decoding.windows import CLOSE, REST, check_labels
from estimation.errors import EstimationInputError


class Unrequested(NamedTuple):
    """Windows where the decoder issued a command nobody asked for.

    Attributes
    ----------
    fraction : float
        ``count / windows`` (NaN when there are no such windows).
    count : int
        Windows with the unrequested command.
    windows : int
        Windows of the label considered.
    """

    fraction: float
    count: int
    windows: int


def _unrequested(decoded: np.ndarray, y: np.ndarray, label: int, column: int) -> Unrequested:
    d = np.asarray(decoded, dtype=float)
    if d.ndim != 2 or d.shape[1] != 2:
        raise EstimationInputError(f"decoded must have shape (n_windows, 2), found {d.shape}")
    labels = check_labels(y, d.shape[0])
    among = labels == label
    count = int(np.sum(among & (d[:, column] > 0.0)))
    windows = int(np.sum(among))
    return Unrequested(count / windows if windows else float("nan"), count, windows)


def unrequested_opens(decoded: np.ndarray, y: np.ndarray) -> Unrequested:
    """Close-labelled (squeeze) windows where the decoder issued an open.

    Parameters
    ----------
    decoded : ndarray, shape (n_windows, 2)
        ``[close_level, open_level]`` per window (a decoder's ``decode``).
    y : ndarray of int, shape (n_windows,)
        The windows' labels: 0 rest, 1 close, 2 open.

    Returns
    -------
    Unrequested
        ``(fraction, count, windows)`` over the close windows.
    """
    return _unrequested(decoded, y, CLOSE, 1)


def unrequested_closes(decoded: np.ndarray, y: np.ndarray) -> Unrequested:
    """Rest-labelled windows where the decoder issued a close.

    Parameters
    ----------
    decoded : ndarray, shape (n_windows, 2)
    y : ndarray of int, shape (n_windows,)

    Returns
    -------
    Unrequested
        ``(fraction, count, windows)`` over the rest windows.
    """
    return _unrequested(decoded, y, REST, 0)
