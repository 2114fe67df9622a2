"""The reacting user: channels with delay and threshold, corrections, anticipation, noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.user.feedback import ForceVibration, SlipVibration
from sim.user.operator import (
    DelayLine,
    OperatorError,
    OperatorParams,
    OperatorParamsError,
    Plan,
    Scene,
)
from sim.user.operators import (
    UnknownFeedbackError,
    UnknownOperatorError,
    check_user,
    feedback_names,
    make_operator,
    operator_names,
)
from sim.user.reacting import ReactingOperator
from sim.user.scripted import ScriptedOperator

DT = 0.01
FS = 200.0


def _plan(level: float = 0.3, seconds: float = 6.0, goal_n: float = 9.0, **task) -> Plan:
    """A plan held on the table (no lift) unless ``task`` gives one."""
    n = int(seconds * FS)
    intent = np.full(n, level)
    intent[: int(FS)] = 0.0  # a second of rest, then the hold
    return Plan(intent=intent, fs_hz=FS, hold_level=level, goal_n=goal_n, force_range_n=30.0,
                **{"lift_height_m": None, **task})


def _scene(t: float, *, slide_m: float = 0.0, grip: float = 5.0, slip: float = 0.0,
           dropped: bool = False, crushed: bool = False, height: float = 0.1,
           contact: bool = True, finger_speed: float = 0.0) -> Scene:
    return Scene(t_s=t, contact=contact, object_in_hand_m=-slide_m, object_height_m=height,
                 dropped=dropped, crushed=crushed, grip_force_n=grip, slip_speed_m_s=slip,
                 finger_speed_rad_s=finger_speed, touching=contact)


def _run(op, scenes, plan=None, seed=0):
    """Perceive each scene (one per control step) and take that step's two samples."""
    op.start(plan or _plan(), control_dt_s=DT, rng=np.random.default_rng(seed))
    out = []
    for s in scenes:
        op.perceive(s)
        out.append(np.asarray(op.intent(2), dtype=float))
    return np.concatenate(out)


def test_parameters_have_sources_ranges_and_refuse_the_impossible() -> None:
    p = OperatorParams()
    assert 0.15 <= p.vision_delay_s <= 0.25 and p.visible_slip_m >= 0.002
    assert 0.04 <= p.motor_noise_cv <= 0.05
    doc = OperatorParams.__doc__
    for name in OperatorParams.ranges():
        assert f"{name} :" in doc  # every field documented (with its source)
    with pytest.raises(OperatorParamsError, match="vision_delay_s: expected a number in 0..1 s"):
        OperatorParams(vision_delay_s=-0.1)
    with pytest.raises(OperatorParamsError, match="motor_noise_cv"):
        OperatorParams(motor_noise_cv=1.5)
    with pytest.raises(OperatorParamsError, match="vibration_levels: expected an integer"):
        OperatorParams(vibration_levels=2.5)
    with pytest.raises(OperatorParamsError, match="above 0"):
        OperatorParams(motor_noise_time_s=0.0)


def test_delay_line_gives_what_went_in_steps_ago() -> None:
    line = DelayLine(3)
    assert [line.push(i) for i in range(6)] == [None, None, None, 0, 1, 2]
    assert [DelayLine(0).push(i) for i in range(3)] == [0, 1, 2]


def test_scripted_user_follows_the_plan_and_takes_no_feedback() -> None:
    plan = _plan()
    out = _run(ScriptedOperator(), [_scene(k * DT, slide_m=0.01) for k in range(300)], plan)
    np.testing.assert_array_equal(out, plan.intent[:600])
    with pytest.raises(OperatorError, match="reacting user only"):
        ScriptedOperator(feedback="slip_vibration")


def test_a_visible_slide_is_corrected_after_the_vision_delay() -> None:
    p = OperatorParams(motor_noise_cv=0.0, vision_noise_m=0.0)
    op = ReactingOperator(p)
    slide_at = 3.0
    scenes = [_scene(k * DT, slide_m=0.003 if k * DT >= slide_at else 0.0) for k in range(500)]
    out = _run(op, scenes)
    assert op.corrections == 1
    assert op.correction_times[0] == pytest.approx(slide_at + p.vision_delay_s, abs=1.5 * DT)
    # the hold level rises by the correction gain along the ramp
    assert out[-1] == pytest.approx(0.3 * (1 + p.correction_gain))
    t_rise = op.correction_times[0] + p.correction_rise_s
    assert out[int(round((op.correction_times[0] - 0.05) * FS))] == pytest.approx(0.3)
    assert out[int(round((t_rise + 0.05) * FS))] == pytest.approx(0.39)


def test_a_slide_below_the_threshold_is_not_seen() -> None:
    op = ReactingOperator(OperatorParams(motor_noise_cv=0.0, vision_noise_m=0.0))
    _run(op, [_scene(k * DT, slide_m=0.0015 if k > 200 else 0.0) for k in range(500)])
    assert op.corrections == 0


def test_slip_vibration_is_felt_sooner_than_the_slide_is_seen() -> None:
    p = OperatorParams(motor_noise_cv=0.0, vision_noise_m=0.0)
    scenes = [_scene(k * DT, slide_m=max(0.0, (k * DT - 3.0) * 0.01),
                     slip=0.01 if k * DT >= 3.0 else 0.0) for k in range(500)]
    seen, felt = ReactingOperator(p), ReactingOperator(p, feedback="slip_vibration")
    _run(seen, scenes)
    _run(felt, scenes)
    # the 2 mm slide at 1 cm/s is visible at 3.2 s and seen 0.2 s later; the burst at 3.0 s
    # is felt after the feedback delay
    assert seen.correction_times[0] == pytest.approx(3.0 + 0.2 + p.vision_delay_s, abs=0.02)
    assert felt.correction_times[0] == pytest.approx(3.0 + p.feedback_delay_s, abs=0.02)
    # corrections are intermittent: none within the refractory period
    assert np.all(np.diff(felt.correction_times) >= p.refractory_s - 1e-9)


def test_force_vibration_steps_towards_the_goal_level() -> None:
    p = OperatorParams(motor_noise_cv=0.0, vibration_noise_levels=0.0)
    dev = ForceVibration(p)
    dev.start(control_dt_s=DT, force_range_n=30.0, rng=np.random.default_rng(0))
    assert [dev.level_of(f) for f in (0.0, 2.9, 3.1, 6.0, 12.0, 18.0, 40.0)] == \
        [0, 0, 1, 1, 2, 3, 4]
    low, high = ReactingOperator(p, "force_vibration"), ReactingOperator(p, "force_vibration")
    _run(low, [_scene(k * DT, grip=7.0) for k in range(300)], _plan(goal_n=12.0))
    _run(high, [_scene(k * DT, grip=17.0) for k in range(300)], _plan(goal_n=12.0))
    assert low.level(3.0) > 0.3 > high.level(3.0)
    on_goal = ReactingOperator(p, "force_vibration")
    _run(on_goal, [_scene(k * DT, grip=11.0) for k in range(300)], _plan(goal_n=12.0))
    assert on_goal.corrections == 0


def test_slip_vibration_bursts_once_per_slip_event() -> None:
    p = OperatorParams()
    dev = SlipVibration(p)
    dev.start(control_dt_s=DT, force_range_n=30.0, rng=np.random.default_rng(0))
    speeds = [0.0] * 10 + [0.02] * 30 + [0.0] * 10 + [0.02] * 5 + [0.0] * 40
    felt = [dev.perceive(_scene(k * DT, slip=v)).slip for k, v in enumerate(speeds)]
    onsets = [k for k, f in enumerate(felt) if f]
    delay = round(p.feedback_delay_s / DT)
    assert onsets == [10 + delay, 50 + delay]


def test_anticipation_plans_the_next_lift_from_the_last() -> None:
    p = OperatorParams(motor_noise_cv=0.0, vision_noise_m=0.0)
    op = ReactingOperator(p)
    _run(op, [_scene(k * DT, slide_m=0.003 if k > 300 else 0.0) for k in range(400)])
    needed = op.finish().final_level
    _run(op, [_scene(k * DT) for k in range(10)])
    assert op.level(0.0) == pytest.approx(needed)  # the first lift programs the next
    op.finish()
    # later lifts move the plan by a falling learning rate (averaging noisy outcomes)
    before = op.level(0.0)
    _run(op, [_scene(k * DT, slide_m=0.003 if k > 300 else 0.0) for k in range(400)])
    corrected = op.finish().final_level
    _run(op, [_scene(k * DT) for k in range(10)])
    rate = max(p.anticipation_weight / 3, p.min_learning_rate)
    assert op.level(0.0) == pytest.approx(before * (corrected / before) ** rate)
    op.finish()
    before = op.level(0.0)
    _run(op, [_scene(k * DT, crushed=k > 50) for k in range(100)])
    broke = op.finish()
    assert broke.break_seen
    _run(op, [_scene(k * DT) for k in range(10)])
    rate = max(p.anticipation_weight / 5, p.min_learning_rate)
    assert op.level(0.0) == pytest.approx(before / (1 + p.correction_gain) ** rate)


def test_motor_noise_is_signal_dependent_with_the_published_cv() -> None:
    cvs = []
    for level in (0.1, 0.5):
        op = ReactingOperator(OperatorParams(vision_noise_m=0.0))
        plan = _plan(level=level, seconds=200.0)
        out = _run(op, [_scene(k * DT) for k in range(int(199 * 100))], plan)
        hold = out[int(2 * FS):]
        cvs.append((np.std(hold), np.std(hold) / np.mean(hold)))
    (sd_lo, cv_lo), (sd_hi, cv_hi) = cvs
    assert sd_hi == pytest.approx(5 * sd_lo, rel=0.1)  # SD grows with the mean
    assert cv_lo == pytest.approx(0.045, rel=0.15) and cv_hi == pytest.approx(0.045, rel=0.15)


def test_the_same_seed_gives_the_same_motor_noise_whatever_the_feedback() -> None:
    p = OperatorParams(vibration_noise_levels=0.0)
    scenes = [_scene(k * DT, grip=12.0) for k in range(400)]  # on the goal's level
    a = _run(ReactingOperator(p), scenes, _plan(goal_n=12.0), seed=4)
    b = _run(ReactingOperator(p, feedback="force_vibration"), scenes, _plan(goal_n=12.0), seed=4)
    np.testing.assert_array_equal(a, b)
    c = _run(ReactingOperator(p), scenes, _plan(goal_n=12.0), seed=5)
    assert not np.array_equal(a, c)


def test_registries_name_the_choices() -> None:
    assert set(operator_names()) >= {"scripted", "reacting"}
    assert set(feedback_names()) >= {"none", "force_vibration", "slip_vibration"}
    with pytest.raises(UnknownFeedbackError, match="none, force_vibration, slip_vibration"):
        check_user("reacting", "buzz")
    with pytest.raises(UnknownOperatorError, match="reacting"):
        make_operator("psychic")
    with pytest.raises(OperatorError, match="user scripted takes feedback none only"):
        check_user("scripted", "force_vibration")
    assert make_operator("reacting", feedback="slip_vibration").feedback.name == "slip_vibration"
    assert math.isfinite(OperatorParams().to_dict()["vision_delay_s"])
