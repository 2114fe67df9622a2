"""The hand reference at each feature window of a person's trial, for its metrics."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenarios.runners.semg_reference import SemgReference


@dataclass(frozen=True)
class ReferenceWindows:
    """The hand reference at each feature window of a trial (its volatility is a metric).

    Attributes
    ----------
    values_n : ndarray, shape (n_windows,)
        The hand reference each window gave, N.
    dt_s : float
        Window increment, s.
    """

    values_n: np.ndarray
    dt_s: float

    @classmethod
    def of(cls, chain: SemgReference, until_s: float) -> ReferenceWindows:
        """The windows of ``chain`` that ended by ``until_s`` (the trial's time limit), s."""
        window_t = np.asarray(chain.window_t_s)
        return cls(np.asarray(chain.window_values_n)[window_t <= until_s],
                   chain.hop / chain.fs_hz)
