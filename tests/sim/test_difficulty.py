"""Estimation-difficulty statistics of a recording, on signals whose answers are known."""

from __future__ import annotations

import numpy as np
import pytest

from sim.user.difficulty import STATISTICS, recording_difficulty, summarize

FS = 200.0


def _squeezes(levels, fs=FS, on_s=4.0, off_s=4.0):
    """Force (N) with rectangular squeezes at ``levels`` x 20 N, and time."""
    parts = [np.zeros(int(off_s * fs))]
    for level in levels:
        parts += [np.full(int(on_s * fs), 20.0 * level), np.zeros(int(off_s * fs))]
    return np.concatenate(parts)


def _emg_following(force, rng, gains=None, lag_samples=0, noise=0.0):
    """8 channels whose MAV is proportional to ``force`` (delayed by ``lag_samples``)."""
    env = np.concatenate([np.full(lag_samples, force[0]), force[:force.size - lag_samples]])
    gains = np.ones(8) if gains is None else np.asarray(gains)
    carrier = np.sign(rng.standard_normal((force.size, 8)))  # |carrier| = 1: MAV = envelope
    return carrier * (env[:, None] * gains[None, :] + 1.0) + noise * rng.standard_normal(
        (force.size, 8))


def test_squeeze_count_peaks_and_duty_of_rectangular_squeezes():
    force = _squeezes([0.5, 0.75, 1.0])
    emg = _emg_following(force, np.random.default_rng(0))
    s = recording_difficulty(emg, force, FS)
    assert s["squeezes"] == 3
    peaks = np.array([0.5, 0.75, 1.0])
    assert s["peak_cv"] == pytest.approx(peaks.std() / peaks.mean(), rel=1e-9)
    # 3 x 4 s above 20 % in 28 s; the 125 ms force windows see the edges exactly
    n_windows = (force.size - 80) // 25 + 1
    assert s["duty"] == pytest.approx(3 * 4 * 8 / n_windows, abs=2 / n_windows)


def test_linear_emg_is_fitted_exactly_in_and_out_of_sample_and_shows_no_drift():
    force = _squeezes([0.6, 1.0, 0.6, 1.0])
    emg = _emg_following(force, np.random.default_rng(1), gains=np.linspace(0.5, 1.5, 8))
    s = recording_difficulty(emg, force, FS)
    # MAV over 400 ms and force over the last 125 ms differ only at the edges of squeezes
    assert s["r2_lin_in"] > 0.9 and s["r2_lin_out"] > 0.9
    assert s["drift"] == pytest.approx(1.0, abs=0.02)
    assert s["nonlin"] == pytest.approx(0.0, abs=0.02)


def test_drift_is_the_ratio_of_emg_per_newton_between_halves():
    force = _squeezes([1.0, 1.0, 1.0, 1.0])
    emg = _emg_following(force, np.random.default_rng(2))
    half = emg.shape[0] // 2
    emg[half:] *= 1.3
    assert recording_difficulty(emg, force, FS)["drift"] == pytest.approx(1.3, abs=0.02)


def test_a_late_emg_envelope_shows_as_a_negative_lag():
    force = _squeezes([0.5, 1.0, 0.7, 0.9])
    rng = np.random.default_rng(4)
    base = recording_difficulty(_emg_following(force, rng), force, FS)["lag_ms"]
    late = recording_difficulty(_emg_following(force, rng, lag_samples=100), force, FS)["lag_ms"]
    assert late - base == pytest.approx(-500.0, abs=125.0)  # 0.5 s later envelope


def test_summary_and_bad_input():
    force = _squeezes([0.5, 1.0])
    rows = [recording_difficulty(_emg_following(force, np.random.default_rng(i)), force, FS)
            for i in range(3)]
    summary = summarize(rows)
    assert set(summary) == set(STATISTICS)
    assert summary["squeezes"] == {"median": 2.0, "mean": 2.0, "min": 2.0, "max": 2.0}
    with pytest.raises(ValueError, match="at least 8 channels|expected emg"):
        recording_difficulty(np.zeros((1000, 3)), np.zeros(1000), FS)
    with pytest.raises(ValueError, match="at least 4 windows"):
        recording_difficulty(np.zeros((100, 8)), np.zeros(100), FS)


def test_inner_outer_of_one_recording():
    from sim.user.difficulty import inner_outer

    inner = {"mlp": 0.5, "ridge": 0.9, "gbt": 0.7, "narx": None, "lda_qpf": float("nan")}
    outer = {"mlp": 0.95, "ridge": 0.80, "gbt": 0.85, "narx": 0.9, "lda_qpf": 0.99}
    row = inner_outer(inner, outer)
    # ridge wins the inner split and loses outside: a reversed ranking
    assert row["pick"] == "ridge" and row["spearman"] == pytest.approx(-1.0)
    assert row["regret"] == pytest.approx(0.95 - 0.80)  # narx and lda_qpf take no part
    assert row["gain"] == pytest.approx(0.80 - 0.95)
    row = inner_outer(inner, outer, reference="gbt")
    assert row["gain"] == pytest.approx(-0.05)
    with pytest.raises(ValueError, match="at least 3 estimators"):
        inner_outer({"mlp": 0.5, "gbt": 0.6}, {"mlp": 0.9, "gbt": 0.8})


def test_summary_of_inner_outer_rows():
    from sim.user.difficulty import summarize_inner_outer

    rows = [{"spearman": s, "regret": r, "gain": g}
            for s, r, g in ((0.5, 0.0, 0.0), (-0.2, 0.1, -0.1), (0.1, 0.05, 0.02))]
    s = summarize_inner_outer(rows)
    assert s["spearman_median"] == pytest.approx(0.1)
    assert (s["spearman_min"], s["spearman_max"]) == (-0.2, 0.5)
    assert s["regret_mean"] == pytest.approx(0.05) and s["gain_min"] == -0.1
    assert s["gain_mean"] == pytest.approx(-0.08 / 3)
