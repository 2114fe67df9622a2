"""The wrist the user moves: minimum-jerk moves on command, and what the hand reports."""

from __future__ import annotations

import numpy as np
import pytest

from sim.hand.errors import HandSpecError
from sim.hand.grasp_env import GraspEnv
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
    env = GraspEnv("can", 8.0, wrist="commanded", terminate_on_drop=False, episode_s=4.0)
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
