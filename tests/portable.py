"""What a test may promise about numbers computed through different paths, on any CPU.

numpy dispatches its loops to the CPU's vector unit (SSE4, AVX2, AVX-512); some of
them, its transcendental functions in particular, compute an element differently
depending on where it falls in the array. A result computed in chunks of other
lengths, in another array shape, on another number of threads or through another code
path can therefore differ in its last bits on one CPU and not on another.

The rule of this suite:

* exact equality only for the same call on the same inputs (a seed run twice, a file
  written and read back) or for integer arithmetic;
* values computed through different shapes, chunkings, thread counts or code paths are
  compared with :func:`assert_close_across_paths` at :data:`PATH_RTOL`, and integers
  rounded from such floats with :func:`assert_rounded_close_across_paths`.

``.ci/run`` runs the suite a second time with numpy's dispatch limited to AVX2
(``NPY_DISABLE_CPU_FEATURES``), so that a test breaking the rule fails on the
developer's machine too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

PATH_RTOL = 1e-12
"""Relative tolerance between two computations of the same value through different paths."""


def assert_close_across_paths(actual: Any, desired: Any, *, rtol: float = PATH_RTOL,
                              err_msg: str = "") -> None:
    """``actual`` equals ``desired`` to ``rtol`` of the largest magnitude of ``desired``.

    The absolute floor (``rtol`` times that magnitude) covers elements near zero, whose
    relative error is not bounded by the rounding of the computation.
    """
    actual = np.asarray(actual, dtype=float)
    desired = np.asarray(desired, dtype=float)
    assert actual.shape == desired.shape, (actual.shape, desired.shape, err_msg)
    finite = desired[np.isfinite(desired)]
    scale = float(np.max(np.abs(finite))) if finite.size else 0.0
    np.testing.assert_allclose(actual, desired, rtol=rtol, atol=rtol * max(scale, 1e-300),
                               err_msg=err_msg)


def assert_rounded_close_across_paths(actual: Any, desired: Any, *,
                                      max_fraction: float = 1e-4) -> None:
    """Integers rounded from floats computed through different paths: equal, but where a
    float fell within its last bits of a rounding boundary (at most 1 apart there, in at
    most ``max_fraction`` of the elements)."""
    actual, desired = np.asarray(actual), np.asarray(desired)
    assert actual.shape == desired.shape, (actual.shape, desired.shape)
    diff = np.abs(actual.astype(np.int64) - desired.astype(np.int64))
    assert int(diff.max(initial=0)) <= 1, f"{int(diff.max())} apart"
    assert np.count_nonzero(diff) <= max_fraction * diff.size, \
        f"{np.count_nonzero(diff)} of {diff.size} differ"


def assert_nested_close_across_paths(actual: Any, desired: Any, *, rtol: float = PATH_RTOL,
                                     path: str = "") -> None:
    """Two nested results (dicts, lists, numbers, strings) are equal, floats to ``rtol``."""
    if isinstance(desired, Mapping):
        assert isinstance(actual, Mapping) and actual.keys() == desired.keys(), path
        for key in desired:
            assert_nested_close_across_paths(actual[key], desired[key], rtol=rtol,
                                             path=f"{path}.{key}")
    elif isinstance(desired, (str, bytes)) or desired is None or isinstance(desired, bool):
        assert actual == desired, path
    elif isinstance(desired, (int, np.integer)):
        assert actual == desired, path
    elif isinstance(desired, (float, np.floating)):
        assert isinstance(actual, (float, np.floating, int)), path
        if np.isnan(desired):
            assert np.isnan(actual), path
        else:
            assert abs(actual - desired) <= rtol * max(abs(desired), 1e-300), \
                f"{path}: {actual!r} != {desired!r}"
    elif isinstance(desired, np.ndarray):
        assert_close_across_paths(actual, desired, rtol=rtol, err_msg=path)
    elif isinstance(desired, Sequence):
        assert len(actual) == len(desired), path
        for i, (a, d) in enumerate(zip(actual, desired, strict=True)):
            assert_nested_close_across_paths(a, d, rtol=rtol, path=f"{path}[{i}]")
    else:
        assert actual == desired, path


def steps_with_equal_inputs(actual: Any, desired: Any) -> int:
    """How many leading elements of two input sequences are bit for bit equal.

    A simulation fed the same inputs computes the same states (the same call on the same
    inputs), so its traces can be compared exactly up to this step; after it they may
    part as chaotic contact amplifies the last bit, and only a tolerance or an outcome can
    be compared.
    """
    actual, desired = np.asarray(actual), np.asarray(desired)
    n = min(actual.size, desired.size)
    differ = np.flatnonzero(actual.ravel()[:n] != desired.ravel()[:n])
    return int(differ[0]) if differ.size else n
