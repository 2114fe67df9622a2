"""Windowed features: equality with a plain per-window loop, closed forms, alignment."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.features import (
    FeatureError,
    align_to_windows,
    emg_features,
    extract_features,
    window_samples,
)
from sim.recording import Recording, RecordingError


def reference_features(emg: np.ndarray, win: int, step: int) -> np.ndarray:
    """The paper's equations 1-3 evaluated window by window in plain Python."""
    rows = []
    for start in range(0, emg.shape[0] - win + 1, step):
        row = []
        for ch in range(emg.shape[1]):
            w = [float(v) for v in emg[start:start + win, ch]]
            mav = sum(abs(v) for v in w) / win
            rms = (sum(v * v for v in w) / win) ** 0.5
            wl = sum(abs(w[k] - w[k - 1]) for k in range(1, win))
            row += [mav, rms, wl]
        rows.append(row)
    return np.array(rows)


@pytest.mark.parametrize("fs_hz", [200.0, 1000.0, 512.0])
def test_matches_plain_loop_at_any_rate(fs_hz: float) -> None:
    rng = np.random.default_rng(1)
    emg = rng.integers(-128, 128, size=(int(fs_hz * 3), 3)).astype(np.int8)
    win, step = window_samples(fs_hz, 400, 125)
    fast = emg_features(emg, fs_hz)
    np.testing.assert_allclose(fast, reference_features(emg, win, step), rtol=1e-12, atol=1e-9)


def test_window_counts_at_200_hz() -> None:
    assert window_samples(200.0, 400, 125) == (80, 25)
    emg = np.zeros((80 + 25 * 9, 2))
    assert emg_features(emg, 200.0).shape == (10, 6)


def test_closed_forms_on_a_square_wave() -> None:
    # Alternating +a/-a: MAV = RMS = a, WL = 2a per consecutive pair.
    a = 5.0
    x = a * np.where(np.arange(400) % 2 == 0, 1.0, -1.0)[:, None]
    feats = emg_features(x, 200.0)
    np.testing.assert_allclose(feats[:, 0], a)
    np.testing.assert_allclose(feats[:, 1], a)
    np.testing.assert_allclose(feats[:, 2], 2 * a * 79)


def test_alignment_last_and_mean() -> None:
    s = np.arange(300, dtype=float)
    last = align_to_windows(s, 200.0, target="last")
    mean = align_to_windows(s, 200.0, target="mean")
    np.testing.assert_array_equal(last, 79 + 25 * np.arange(last.size))
    np.testing.assert_allclose(mean, last - 39.5)


def test_extract_features_selects_paper_channels_in_order() -> None:
    rng = np.random.default_rng(2)
    emg = rng.integers(-20, 20, size=(600, 8)).astype(np.int8)
    rec = Recording(emg=emg, fs_hz=200.0, force_n=np.linspace(0, 30, 600),
                    intent=np.linspace(0, 1, 600))
    fs = extract_features(rec)
    assert fs.names[:3] == ("emg6_mav", "emg6_rms", "emg6_wl")
    assert fs.names[-1] == "emg8_wl"
    np.testing.assert_allclose(fs.X, emg_features(emg[:, 5:8], 200.0))
    np.testing.assert_allclose(fs.columns("rms"), fs.X[:, [1, 4, 7]])
    assert fs.dt_s == pytest.approx(0.125)
    np.testing.assert_allclose(fs.t_s, (79 + 25 * np.arange(fs.n_windows)) / 200.0)
    np.testing.assert_allclose(fs.y, rec.force_n[79::25][: fs.n_windows])


def test_bad_input_is_named() -> None:
    rec = Recording(emg=np.zeros((50, 8), np.int8), fs_hz=200.0)
    with pytest.raises(FeatureError, match="fewer than one 400"):
        extract_features(rec)
    with pytest.raises(RecordingError, match="unknown channel 12"):
        extract_features(Recording(emg=np.zeros((100, 8)), fs_hz=200.0), channels=(6, 12))
    with pytest.raises(FeatureError, match="NaN"):
        emg_features(np.full((100, 2), np.nan), 200.0)
    with pytest.raises(FeatureError, match="unknown features"):
        emg_features(np.zeros((100, 2)), 200.0, features=("zc",))
    with pytest.raises(FeatureError, match="at least 2"):
        window_samples(1.0, 400, 125)


@pytest.mark.portable
def test_int8_prefix_sums_stay_exact_past_int32_overflow() -> None:
    # 150k full-scale samples: the running sum of squares (2.5e9) exceeds int32.
    n = 150_000
    emg = np.where(np.arange(n) % 3 == 0, -128, 127).astype(np.int8)[:, None]
    fast = emg_features(emg, 200.0)
    exact = emg_features(emg.astype(np.float64), 200.0)
    np.testing.assert_array_equal(fast, exact)
    assert np.all(fast[:, 1] > 120)
