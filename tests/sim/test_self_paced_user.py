"""The user's own arm: the trial's phases, trying again, touch, and what practice teaches."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.user.belief import ProsthesisBelief
from sim.user.operator import FRAGILE_MARGIN, MIN_GRIP_N, OperatorParams, Plan, Scene, TrialMemory
from sim.user.reacting import ReactingOperator

DT = 0.01
FS = 200.0
QUIET = OperatorParams(motor_noise_cv=0.0, vision_noise_m=0.0)


def _plan(**task) -> Plan:
    n = int(15.0 * FS)
    intent = np.full(n, 0.3)
    intent[: int(FS)] = 0.0  # a second of rest, then the hold
    return Plan(intent=intent, fs_hz=FS, hold_level=0.3, goal_n=9.0, force_range_n=30.0,
                need_n=4.0, level_per_n=0.3 / 9.0, **{"hold_s": 1.0, **task})


class _World:
    """A scripted hand: closes at 1.5 s, follows the wrist; the object stays on the table
    whenever the wrist rises before ``stays_behind_s``."""

    def __init__(self, stays_behind_s: float = 0.0) -> None:
        self.wrist = 0.0
        self.target = 0.0
        self.stays_behind_s = stays_behind_s

    def scene(self, t: float) -> Scene:
        closed = t >= 1.5
        behind = t < self.stays_behind_s and self.wrist > 0
        height = 0.06 + (0.0 if behind else self.wrist)
        return Scene(t_s=t, contact=closed and not (behind and self.wrist > 0.003),
                     object_in_hand_m=-(self.wrist if behind else 0.0), object_height_m=height,
                     dropped=False, crushed=False, grip_force_n=5.0 if closed else 0.0,
                     slip_speed_m_s=0.0, finger_speed_rad_s=0.0 if closed else 0.6,
                     touching=closed)

    def run(self, op: ReactingOperator, plan: Plan, seconds: float = 15.0) -> None:
        op.start(plan, control_dt_s=DT, rng=np.random.default_rng(0))
        moves: list[tuple[float, float, float]] = []
        for k in range(int(seconds / DT)):
            t = k * DT
            op.perceive(self.scene(t))
            move = op.wrist_move()
            if move is not None:
                moves.append((t, move.height_m, move.duration_s))
                self.target = move.height_m
            self.wrist += float(np.clip(self.target - self.wrist, -0.002, 0.002))
            if op.done:
                break
        self.moves = moves


def _phases(op: ReactingOperator) -> list[str]:
    return [name for _, name in op.phase_log]


def test_a_secure_grip_is_lifted_carefully_held_put_down_and_released() -> None:
    op, world = ReactingOperator(QUIET), _World()
    world.run(op, _plan())
    assert _phases(op) == ["grasp", "liftoff", "lift", "setdown", "release", "done"]
    assert op.attempts == 1 and op.corrections == 0 and op.done
    t_liftoff = op.phase_log[1][0]
    # lifts once the hand has been seen closed and still for the dwell (seen 0.2 s late)
    assert t_liftoff == pytest.approx(1.5 + QUIET.vision_delay_s + QUIET.dwell_s, abs=2 * DT)
    heights = [h for _, h, _ in world.moves]
    assert heights[:3] == [QUIET.liftoff_height_m, 0.08, 0.0]


def test_an_object_left_behind_at_lift_off_is_put_down_squeezed_and_tried_again() -> None:
    op, world = ReactingOperator(QUIET), _World(stays_behind_s=2.5)
    world.run(op, _plan())
    assert op.attempts == 2 and op.corrections == 1
    assert _phases(op)[:4] == ["grasp", "liftoff", "grasp", "liftoff"]
    assert [h for _, h, _ in world.moves][:3] == [QUIET.liftoff_height_m, 0.0,
                                                  QUIET.liftoff_height_m]
    assert op.level(14.0) == pytest.approx(0.0)  # released at the end
    memory = op.finish()
    assert memory.attempts == 2 and memory.slip_seen
    assert memory.final_level == pytest.approx(memory.planned_level * (1 + QUIET.correction_gain))


def test_touch_lifts_without_a_careful_lift_off() -> None:
    op, world = ReactingOperator(QUIET, feedback="touch"), _World()
    world.run(op, _plan())
    assert "liftoff" not in _phases(op) and op.attempts == 1
    t_lift = op.phase_log[1][0]
    assert t_lift == pytest.approx(1.5 + QUIET.touch_delay_s + QUIET.touch_dwell_s, abs=2 * DT)


@pytest.mark.parametrize("slip_at_s, answered", [(1.5, False), (3.0, True)])
def test_on_the_table_a_slip_as_the_hand_closes_is_not_a_slip_of_a_held_object(
        slip_at_s: float, answered: bool) -> None:
    """Force matching: the closing digits push the object (a burst at contact); later a
    slip of the object the hand holds is squeezed for, as in the air."""

    class Pushed(_World):
        def scene(self, t: float) -> Scene:
            s = super().scene(t)
            fast = slip_at_s <= t < slip_at_s + 0.05
            return dataclasses.replace(s, slip_speed_m_s=0.05 if fast else 0.0)

    op, world = ReactingOperator(QUIET, feedback="touch"), Pushed()
    world.run(op, _plan(lift_height_m=None, hold_s=5.0), seconds=5.0)
    assert _phases(op) == ["hold"]
    assert op.corrections == (1 if answered else 0)


def test_a_hand_that_does_not_close_is_squeezed_for() -> None:
    op = ReactingOperator(QUIET)
    plan = _plan()
    op.start(plan, control_dt_s=DT, rng=np.random.default_rng(0))
    for k in range(400):  # the hand stays open and still
        op.perceive(Scene(k * DT, False, 0.0, 0.06, False, False, 0.0, 0.0, 0.0, False))
    assert op.corrections >= 2
    assert np.diff(op.correction_times).min() >= QUIET.refractory_s - 1e-9


def test_the_aim_covers_the_margin_and_spares_a_fragile_object() -> None:
    plan = _plan()
    assert plan.aim_n(0.5) == pytest.approx(6.0)
    assert plan.aim_n(0.0) == pytest.approx(max(4.0, MIN_GRIP_N))
    fragile = _plan(break_n=5.0)
    assert fragile.aim_n(0.5) == pytest.approx(FRAGILE_MARGIN * 5.0)
    target = Plan(intent=plan.intent, fs_hz=FS, hold_level=0.3, goal_n=9.0, force_range_n=30.0)
    assert target.aim_n(3.0) == 9.0  # a force target is aimed at as it is
    assert target.level_of(9.0) == pytest.approx(0.3)


def test_a_novice_keeps_the_novice_margin_and_clean_lifts_bring_it_to_the_intact_one() -> None:
    p = OperatorParams()
    novice = ProsthesisBelief.novice(p)
    assert novice.gain == 1.0 and novice.margin(p) == pytest.approx(p.novice_margin)
    belief = novice
    for _ in range(50):  # every lift as planned (an intact hand, the oracle)
        belief = belief.learn(TrialMemory(0.2, 0.2), p)
    assert belief.gain == 1.0
    assert belief.margin(p) == pytest.approx(p.intact_margin, abs=1e-3)
    assert 0.10 <= ProsthesisBelief.novice(p).learn(TrialMemory(0.2, 0.2), p).margin(p) <= 0.5


def test_errors_met_raise_the_gain_and_the_margin() -> None:
    p = OperatorParams()
    rng = np.random.default_rng(1)
    noisy = ProsthesisBelief.novice(p)
    for _ in range(8):  # outcomes that needed 0-2 squeezes more than planned
        k = int(rng.integers(0, 3))
        noisy = noisy.learn(TrialMemory(0.2, 0.2 * (1 + p.correction_gain) ** k), p)
    assert noisy.gain > 1.0 and noisy.margin(p) > p.novice_margin
    dropped = ProsthesisBelief.novice(p).learn(TrialMemory(0.2, 0.2, drop_seen=True), p)
    assert dropped.gain == pytest.approx(1.0 + p.correction_gain)  # the first lift: all of it
    broke = ProsthesisBelief.novice(p).learn(TrialMemory(0.2, 0.2, break_seen=True), p)
    assert broke.gain == pytest.approx(1.0 / (1.0 + p.correction_gain))
    assert ProsthesisBelief.from_dict(noisy.to_dict()) == noisy
    with pytest.raises(ValueError, match="belief"):
        ProsthesisBelief.from_dict({"gain": -1.0, "uncertainty": 0.1, "lifts": 2})
