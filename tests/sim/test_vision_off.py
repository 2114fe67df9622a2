"""The reacting user without vision: only the digits heard moving, and their feedback.

Scenes are synthetic (one per 10 ms control step), so each test states what the user
could perceive and checks what they did with it, against the same scenes seen.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.user.operator import OperatorParams, Plan, Scene
from sim.user.reacting import ReactingOperator

DT = 0.01
FS = 200.0
CLOSING_S = (1.5, 2.0)
"""The hand's digits move in this window of every grasp below (the motor runs), and touch
the object from its end on, s."""
CARRIED_S = 4.0
"""By then both users have lifted the object (it is 8 cm up in the hand), s."""


def _lift_plan(*, sees: bool, seconds: float = 12.0) -> Plan:
    """A grasp, a lift to 8 cm and a 1 s hold, with a second of rest first."""
    n = int(seconds * FS)
    intent = np.full(n, 0.3)
    intent[: int(FS)] = 0.0
    return Plan(intent=intent, fs_hz=FS, hold_level=0.3, goal_n=9.0, force_range_n=30.0,
                need_n=3.0, lift_height_m=0.08, hold_s=3.0, limit_s=seconds, sees=sees)


def _scene(t: float, *, contact: bool = True, grip: float = 6.0, dropped: bool = False,
           slide_m: float = 0.0, moving: bool | None = None) -> Scene:
    if moving is None:
        moving = CLOSING_S[0] <= t < CLOSING_S[1]
    contact = contact and not dropped and t >= CLOSING_S[1]
    return Scene(t_s=t, contact=contact, object_in_hand_m=-slide_m,
                 object_height_m=0.03 + (0.08 if t >= CARRIED_S and not dropped else 0.0),
                 dropped=dropped, crushed=False,
                 grip_force_n=grip if contact else 0.0, slip_speed_m_s=0.0,
                 finger_speed_rad_s=2.0 if moving else 0.0, touching=contact)


def _run(op: ReactingOperator, plan: Plan, scene_at, steps: int = 1200) -> list[float]:
    """Perceive ``scene_at(t)`` every step until the user is done; the step times."""
    op.start(plan, control_dt_s=DT, rng=np.random.default_rng(0))
    times = []
    for k in range(steps):
        t = k * DT
        op.perceive(scene_at(t))
        op.intent(2)
        times.append(t)
        if op.done:
            break
    return times


def _params() -> OperatorParams:
    return OperatorParams(motor_noise_cv=0.0, vision_noise_m=0.0)


def _phase_at(op: ReactingOperator, phase: str) -> float:
    return next(t for t, name in op.phase_log if name == phase)


def test_without_vision_the_user_lifts_once_the_motor_fell_silent_without_a_careful_liftoff(
) -> None:
    seeing, blind = ReactingOperator(_params()), ReactingOperator(_params())
    _run(seeing, _lift_plan(sees=True), lambda t: _scene(t))
    _run(blind, _lift_plan(sees=False), lambda t: _scene(t))
    # seen: a careful lift-off first; heard: straight to the lift (nothing to watch)
    assert "liftoff" in [name for _, name in seeing.phase_log]
    assert "liftoff" not in [name for _, name in blind.phase_log]
    # heard silent at the end of the closing plus one perception delay, then the dwell
    p = _params()
    lift = _phase_at(blind, "lift")
    assert lift >= CLOSING_S[1] + p.vision_delay_s + p.dwell_s - 2 * DT
    assert lift <= CLOSING_S[1] + p.vision_delay_s + p.dwell_s + p.correction_rise_s + 0.1


def test_the_hand_heard_moving_before_the_contraction_is_not_a_closing() -> None:
    # the hand is set open in the first half second (its motor runs), then never moves:
    # the user, who has not contracted yet, does not take that for their hand closing
    blind = ReactingOperator(_params())
    _run(blind, _lift_plan(sees=False),
         lambda t: _scene(t, contact=False, grip=0.0, moving=t < 0.5), steps=600)
    assert "lift" not in [name for _, name in blind.phase_log]
    assert blind.corrections >= 2  # silent while contracting: squeezed for harder


def test_a_drop_is_seen_with_vision_and_missed_without_it() -> None:
    def dropping(t: float) -> Scene:
        return _scene(t, dropped=t >= 4.5)

    seeing, blind = ReactingOperator(_params()), ReactingOperator(_params())
    _run(seeing, _lift_plan(sees=True), dropping)
    _run(blind, _lift_plan(sees=False), dropping)
    assert seeing.finish().drop_seen
    blind_memory = blind.finish()
    assert not blind_memory.drop_seen
    # the user who does not see it carries on: sets down and lets go as planned
    assert [name for _, name in blind.phase_log][-3:] == ["setdown", "release", "done"]


def test_force_vibration_tells_a_blind_user_the_grip_and_its_loss() -> None:
    def dropping(t: float) -> Scene:
        return _scene(t, dropped=t >= 4.5)

    blind = ReactingOperator(_params(), feedback="force_vibration")
    _run(blind, _lift_plan(sees=False), dropping)
    assert blind.finish().drop_seen  # the vibration stopped: the object is gone
    assert "setdown" not in [name for _, name in blind.phase_log]


def test_a_silent_hand_is_squeezed_for_and_a_grip_not_felt_is_not_lifted() -> None:
    # the hand never moves: without vision the user hears nothing and squeezes harder
    still = ReactingOperator(_params())
    _run(still, _lift_plan(sees=False), lambda t: _scene(t, contact=False, grip=0.0,
                                                         moving=False), steps=600)
    assert still.corrections >= 2
    assert "lift" not in [name for _, name in still.phase_log]
    # the motor ran and stopped but no grip is felt (closed on nothing): with force
    # feedback the user does not lift; without feedback they cannot tell and lift
    empty = lambda t: _scene(t, contact=False, grip=0.0)  # noqa: E731
    felt = ReactingOperator(_params(), feedback="force_vibration")
    _run(felt, _lift_plan(sees=False), empty, steps=600)
    assert "lift" not in [name for _, name in felt.phase_log]
    deaf_to_grip = ReactingOperator(_params())
    _run(deaf_to_grip, _lift_plan(sees=False), empty, steps=600)
    assert "lift" in [name for _, name in deaf_to_grip.phase_log]


def test_without_vision_the_hand_is_taken_as_open_once_heard_opening() -> None:
    p = _params()
    blind = ReactingOperator(p)
    release_at: list[float] = []

    def opening(t: float) -> Scene:
        if blind.phase == "release" and not release_at:
            release_at.append(t)
        if release_at and release_at[0] + 0.3 <= t < release_at[0] + 0.6:
            return _scene(t, moving=True)
        return _scene(t)

    _run(blind, _lift_plan(sees=False), opening)
    assert blind.done and blind.released
    # done once the opening is heard to stop (delay included), not at the first silence
    assert _phase_at(blind, "done") >= release_at[0] + 0.6 + p.vision_delay_s - 2 * DT
    never = ReactingOperator(p)
    _run(never, _lift_plan(sees=False), lambda t: _scene(t))  # the hand never opens
    assert never.done and not never.released


def test_with_vision_the_plan_field_changes_nothing() -> None:
    a, b = ReactingOperator(_params()), ReactingOperator(_params())
    plan = _lift_plan(sees=True)
    ta = _run(a, plan, lambda t: _scene(t))
    tb = _run(b, Plan(**{**plan.__dict__}), lambda t: _scene(t))
    assert ta == tb and a.phase_log == b.phase_log
    assert plan.sees and Plan(intent=np.zeros(4), fs_hz=FS, hold_level=0.0, goal_n=1.0,
                              force_range_n=1.0).sees


@pytest.mark.parametrize("feedback", ["none", "slip_vibration"])
def test_without_vision_a_slide_is_not_seen(feedback: str) -> None:
    def sliding(t: float) -> Scene:
        return _scene(t, slide_m=0.01 if t >= 4.5 else 0.0)

    seeing = ReactingOperator(_params(), feedback=feedback)
    _run(seeing, _lift_plan(sees=True), sliding)
    assert seeing.finish().slip_seen
    blind = ReactingOperator(_params(), feedback=feedback)
    _run(blind, _lift_plan(sees=False), sliding)
    assert not blind.finish().slip_seen  # a slide with no slip sensor event: unnoticed
