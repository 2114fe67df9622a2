"""The one feature window of every trial: chunks of any length give the batch's windows.

int8 windows are integer sums, equal to :func:`estimation.features.emg_features` bit for
bit; float windows are summed in another order than the batch's prefix sums: equal to
PATH_RTOL (tests/portable.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from portable import assert_close_across_paths

from estimation.feature_window import FeatureWindow
from estimation.features import FeatureError, emg_features, extract_features
from sim.user.intent import paper_protocol
from sim.user.subjects import VirtualSubject


def _chunked(window: FeatureWindow, x: np.ndarray, rng: np.random.Generator,
             max_chunk: int) -> tuple[np.ndarray, np.ndarray]:
    rows, ends, i = [], [], 0
    while i < x.shape[0]:
        m = int(rng.integers(1, max_chunk + 1))
        r, e = window.push(x[i:i + m])
        rows.append(r)
        ends.append(e)
        i += m
    return np.concatenate(rows), np.concatenate(ends)


@pytest.mark.portable
@pytest.mark.parametrize("dtype", ["int8", "float64"])
@pytest.mark.parametrize("max_chunk", [1, 7, 300])
def test_windows_of_any_chunking_equal_the_batch(dtype, max_chunk) -> None:
    same = np.testing.assert_array_equal if dtype == "int8" else assert_close_across_paths
    rng = np.random.default_rng(3)
    n = 2003
    if dtype == "int8":
        x = rng.integers(-128, 128, size=(n, 8)).astype(np.int8)
    else:
        x = rng.normal(0.0, 40.0, size=(n, 8)) * np.exp(rng.normal(0, 2, size=(n, 1)))
    for fs, channels in ((200.0, [5, 6, 7]), (1000.0, list(range(8))), (150.0, [0]),
                         (200.0, [7, 2])):
        w = FeatureWindow(fs, channels, integer=dtype == "int8")
        rows, ends = _chunked(w, x, rng, max_chunk)
        same(rows, emg_features(x[:, channels], fs), err_msg=f"{fs} {channels}")
        # each window's last sample, counted from the reset
        np.testing.assert_array_equal(ends, w.window - 1 + w.step * np.arange(ends.size))
        assert w.n_windows == ends.size and w.count == n
        # after a reset the windows start again with the next sample
        w.reset()
        rows, _ = _chunked(w, x[500:], rng, max_chunk)
        same(rows, emg_features(x[500:, channels], fs))


def test_a_subject_recording_gives_the_paper_features() -> None:
    rec = VirtualSubject.sample(0, 1).record(paper_protocol(0), rng=1)
    w = FeatureWindow(rec.fs_hz, [5, 6, 7])
    rows, _ = _chunked(w, rec.emg, np.random.default_rng(0), 40)
    np.testing.assert_array_equal(rows, extract_features(rec).X)


def test_a_chunk_that_ends_no_window_returns_none_and_keeps_the_tail() -> None:
    w = FeatureWindow(200.0, [0])
    rows, ends = w.push(np.ones((79, 1), dtype=np.int8))
    assert rows.shape == (0, 3) and ends.size == 0 and w.next_end() == 79
    rows, ends = w.push(np.full((1, 1), 3, dtype=np.int8))
    assert ends.tolist() == [79]
    # MAV, RMS, WL of 79 ones and a three: exact
    np.testing.assert_array_equal(rows[0], [82 / 80, np.sqrt(88 / 80), 2.0])


@pytest.mark.parametrize("kwargs, match", [
    ({"features": ["mav", "zc"]}, "unknown features"),
    ({"channel_index": []}, "at least one channel"),
    ({"window_ms": 5.0}, "window of at least 2 samples"),
])
def test_bad_settings_are_refused(kwargs, match) -> None:
    args = {"fs_hz": 200.0, "channel_index": [0], **kwargs}
    with pytest.raises(FeatureError, match=match):
        FeatureWindow(args.pop("fs_hz"), args.pop("channel_index"), **args)
