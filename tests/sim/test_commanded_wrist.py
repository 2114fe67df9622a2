"""The wrist the user moves: minimum-jerk moves on command, and what the hand reports."""

from __future__ import annotations

import numpy as np
import pytest

from sim.hand.errors import HandSpecError
from sim.hand.grasp_env import GraspEnv, GraspTask
from sim.hand.wrist import CommandedWrist, min_jerk


def test_a_move_follows_the_minimum_jerk_path_from_where_the_wrist_is() -> None:
    w = CommandedWrist()
    assert w.height_m(1.0) == 0.0 and not w.moves_during(0.0, 10.0)
    w.move(1.0, 0.08, 0.6)
    for s in (0.0, 0.25, 0.5, 1.0):
        assert w.height_m(1.0 + 0.6 * s) == pytest.approx(0.08 * min_jerk(s))
    assert w.moves_during(1.2, 1.3) and not w.moves_during(1.7, 2.0)
    assert w.first_rise_s == 1.0 and w.settled(1.6)
    w.move(1.3, 0.0, 0.5)  # a new command mid-move starts from the current set-point
    start = 0.08 * min_jerk(0.5)
    assert w.height_m(1.3) == pytest.approx(start)
    assert w.height_m(1.55) == pytest.approx(start * (1 - min_jerk(0.5)))
    assert w.first_rise_s == 1.0


@pytest.mark.parametrize("height, duration, match", [
    (-0.01, 0.5, "wrist height"), (0.5, 0.5, "wrist height"), (float("nan"), 0.5, "height"),
    (0.05, 0.0, "duration"), (0.05, float("inf"), "duration")])
def test_impossible_moves_are_refused(height, duration, match) -> None:
    with pytest.raises(HandSpecError, match=match):
        CommandedWrist().move(0.0, height, duration)


def test_the_env_lifts_the_held_object_only_when_told() -> None:
    env = GraspEnv("can", 8.0, wrist="commanded",
                   task=GraspTask(episode_s=4.0, terminate_on_drop=False))
    with pytest.raises(HandSpecError, match="wrist="):
        GraspEnv("can", 8.0).move_wrist(0.05, 0.5)
    _, info = env.reset(seed=0)
    u = np.array([0.3], dtype=np.float32)
    for _ in range(100):  # close on the can, then hold it: the wrist stays down
        _, _, _, _, info = env.step(u)
    assert info["wrist_height_m"] == 0.0 and not info["lifted"]
    rest = info["object_height_m"]
    env.move_wrist(0.05, 0.5)
    for _ in range(80):
        _, _, terminated, _, info = env.step(u)
    assert info["lifted"] and info["wrist_height_m"] == pytest.approx(0.05)
    assert info["object_height_m"] - rest == pytest.approx(0.05, abs=0.005)
    assert not info["object_out_of_hand"] and not terminated
    env.close()


def test_follow_moves_keep_the_set_point_and_its_speed_continuous() -> None:
    """A stream of follow moves, one per 20 ms sample of an arm: no jump in position or
    speed at a sample, the speed is the position's derivative, and a held height is
    reached as a critically damped approach (no overshoot)."""
    w = CommandedWrist()
    tau, period, per = 0.05, 0.02, 200
    dt = period / per
    arm = [0.08 * min_jerk((k * period - 0.1) / 0.6) for k in range(60)]
    heights, speeds = [], []
    for i in range(60 * per):
        t = i * dt
        if i % per == 0:  # a sample of the arm: just before and at it, the same state
            before_h, before_v = w.height_m(t), w.speed_m_s(t)
            w.move(t, arm[i // per], tau, "follow")
            assert w.height_m(t) == pytest.approx(before_h, abs=1e-12)
            assert w.speed_m_s(t) == pytest.approx(before_v, abs=1e-9)
        heights.append(w.height_m(t))
        speeds.append(w.speed_m_s(t))
    heights, speeds = np.array(heights), np.array(speeds)
    np.testing.assert_allclose(np.gradient(heights, dt)[1:-1], speeds[1:-1], atol=2e-3)
    assert abs(heights[-1] - 0.08) < 1e-3 and heights.max() <= 0.08 + 1e-9
    # the lag of a critically damped follower behind a ramp is twice its time constant
    end = 60 * period
    w.move(end, 0.05, tau, "follow")
    assert w.moves_during(end, end + 0.01) and not w.settled(end + 0.5)
    assert w.settled(end + 20 * tau) and w.height_m(end + 20 * tau) == pytest.approx(0.05,
                                                                                    abs=1e-7)
    with pytest.raises(HandSpecError, match="path"):
        w.move(end, 0.05, tau, "linear")


def test_a_minimum_jerk_move_reports_its_speed() -> None:
    w = CommandedWrist()
    w.move(1.0, 0.08, 0.6)
    # the derivative of 0.08 * min_jerk(s) / 0.6, computed independently
    for s in (0.1, 0.5, 0.9):
        h = 1e-6
        slope = (0.08 * min_jerk(s + h / 0.6) - 0.08 * min_jerk(s - h / 0.6)) / (2 * h)
        assert w.speed_m_s(1.0 + 0.6 * s) == pytest.approx(slope, rel=1e-6)
    assert w.speed_m_s(1.7) == 0.0 and w.speed_m_s(0.9) == 0.0
