"""Samples as a stream delivers them, made into samples the windows can take."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sim.recording import MAX_EMG_ABS

#: The range of an int8 sEMG count.
INT8_RANGE = (-128, 127)



def parse_numbers(arr: np.ndarray) -> np.ndarray:
    """Float values of a string, bytes or object array, same shape; what does not parse is NaN."""
    out = np.empty(arr.shape, dtype=np.float64)
    flat, values = out.reshape(-1), arr.reshape(-1)
    for i, v in enumerate(values):
        try:
            flat[i] = float(v.decode() if isinstance(v, bytes) else v)
        except (TypeError, ValueError, UnicodeDecodeError):
            flat[i] = math.nan
    return out

class SampleGuard:
    """Turns whatever a stream delivers into samples the windows can take.

    Non-numeric values (strings that are not numbers, NaN, inf) become 0; values
    outside the calibration's range (int8 counts: -128..127; other units:
    +-``MAX_EMG_ABS``) are clipped; integer streams are rounded to counts. Each
    sample with at least one such value is counted once per kind.

    Parameters
    ----------
    integer : bool
        int8 counts (output int64) or another unit (output float64).
    """

    def __init__(self, integer: bool) -> None:
        self.integer = bool(integer)
        self.lo, self.hi = INT8_RANGE if integer else (-MAX_EMG_ABS, MAX_EMG_ABS)
        self.dtype = np.dtype(np.int64 if integer else np.float64)
        self.non_numeric = 0
        self.out_of_range = 0

    def clean(self, samples: Any) -> np.ndarray:
        """Samples as an array (n_samples, n_channels) of ``dtype``, bad values fixed."""
        arr = np.asarray(samples)
        if arr.dtype.kind in "iu" and self.integer:
            if arr.dtype.itemsize == 1 and arr.dtype.kind == "i":
                return arr.astype(np.int64)
            x = arr.astype(np.int64)
            bad = (x < self.lo) | (x > self.hi)
            if bad.any():
                self.out_of_range += int(bad.any(axis=1).sum())
                np.clip(x, self.lo, self.hi, out=x)
            return x
        if arr.dtype.kind not in "iuf":
            arr = parse_numbers(arr)
        x = arr.astype(np.float64)
        finite = np.isfinite(x)
        if not finite.all():
            self.non_numeric += int((~finite).any(axis=1).sum())
            x[~finite] = 0.0
        bad = (x < self.lo) | (x > self.hi)
        if bad.any():
            self.out_of_range += int(bad.any(axis=1).sum())
            np.clip(x, self.lo, self.hi, out=x)
        if self.integer:
            return np.rint(x).astype(np.int64)
        return x
