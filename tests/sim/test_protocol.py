"""Intent profiles: the paper's three squeezes, ramps and grasp-lift-hold."""

from __future__ import annotations

import numpy as np
import pytest

from sim.user.intent import (
    ProfileError,
    from_segments,
    grasp_lift_hold,
    paper_protocol,
    ramp_profile,
)


@pytest.mark.parametrize("seed", range(5))
def test_paper_protocol_has_two_rounds_of_three_squeezes_between_ordered_cues(seed):
    p = paper_protocol(seed)
    assert len(p.levels) == 6
    first, second = p.levels[:3], p.levels[3:]
    # the strongest squeeze of the first round is 85-100 % MVC; the small one 30-70 % of it,
    # each level then scaled by a log-normal error of SD <= 0.3 (3 SD: x0.41..2.46)
    assert all(0.05 <= v <= 1.0 for v in p.levels)
    assert max(first) >= 0.85 * np.exp(-0.9)
    assert max(second) <= 1.0 and np.mean(second) <= np.mean(first) * 2.5
    kinds = [k for k, _ in p.cues]
    times = [t for _, t in p.cues]
    assert kinds == ["start", "end"] * 6
    assert np.all(np.diff(times) > 2.5 * 0.85 - 0.5)
    assert 45.0 <= p.duration_s <= 80.0
    assert p.intent[0] == 0.0 and p.intent[-1] == 0.0
    assert p.intent.min() >= 0.0 and p.intent.max() <= 1.0
    for level, t0, t1 in zip(p.levels, times[::2], times[1::2], strict=True):
        hold = (p.t_s > t0 + 1.5) & (p.t_s < t1)
        np.testing.assert_allclose(p.intent[hold], level, atol=1e-12)
        before = p.t_s < t0
        assert np.all(p.intent[before & (p.t_s > t0 - 2.0)] == 0.0)  # rest before the cue
    # smooth: the steepest raised-cosine ramp (1.0 level over >= 0.6 s) bounds the slope
    assert np.max(np.abs(np.diff(p.intent))) * p.fs_hz <= np.pi / 2 / 0.6 + 1e-9


def test_the_identification_half_holds_the_first_round():
    # with two rounds the paper's 50 % split falls near the end of the first round
    for seed in range(20):
        p = paper_protocol(seed)
        ends = p.cue_times("end")
        starts = p.cue_times("start")
        half = p.duration_s / 2
        assert ends[2] - 1.0 < half < starts[3] + 1.0


def test_fixed_levels_and_rounds():
    p = paper_protocol(0, levels=(0.2, 0.5, 0.9), rounds=1)
    assert p.levels == (0.2, 0.5, 0.9) and len(p.cues) == 6
    assert paper_protocol(0, levels=(0.2, 0.5, 0.9), rounds=3).levels == (0.2, 0.5, 0.9) * 3
    with pytest.raises(ProfileError, match="at least 1 round"):
        paper_protocol(0, rounds=0)


def test_paper_protocol_is_reproducible_and_jittered():
    a, b, c = paper_protocol(1), paper_protocol(1), paper_protocol(2)
    np.testing.assert_array_equal(a.intent, b.intent)
    assert a.cues == b.cues and a.cues != c.cues and a.levels != c.levels


def test_raised_cosine_segment_midpoint_and_validation():
    p = from_segments([(1.0, 0.0), (1.0, 0.8), (1.0, 0.8)], fs_hz=100.0)
    assert p.intent[150] == pytest.approx(0.4)  # halfway up the ramp
    assert p.n_samples == 300 and p.duration_s == 3.0
    with pytest.raises(ProfileError, match="end_level in 0..1"):
        from_segments([(1.0, 1.5)], fs_hz=100.0)
    with pytest.raises(ProfileError, match="3 levels, found 2"):
        paper_protocol(0, levels=(0.2, 0.5))


def test_grasp_lift_hold_rests_ramps_holds_and_releases():
    p = grasp_lift_hold(0, hold_level=0.4, jitter=0.0)
    start, end = p.cue_times("start")[0], p.cue_times("end")[0]
    assert start == pytest.approx(1.0) and end == pytest.approx(5.5)
    hold = (p.t_s >= start + 0.5) & (p.t_s < end)
    np.testing.assert_allclose(p.intent[hold], 0.4)
    assert p.intent[p.t_s < start].max() == 0.0 and p.intent[-1] == 0.0
    assert p.duration_s == pytest.approx(7.0)


def test_ramp_profile_reaches_each_peak():
    p = ramp_profile(3, peaks=(0.3, 0.7))
    for peak, t_end in zip((0.3, 0.7), p.cue_times("end"), strict=True):
        assert p.intent[int(t_end * p.fs_hz) - 1] == pytest.approx(peak)


def test_resampling_keeps_shape_and_cues():
    p = paper_protocol(0, fs_hz=200.0)
    q = p.resampled(1000.0)
    assert q.duration_s == pytest.approx(p.duration_s, abs=1e-3) and q.cues == p.cues
    np.testing.assert_allclose(q.intent[::5][: p.n_samples], p.intent, atol=1e-12)
