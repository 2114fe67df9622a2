"""The one trial loop: one route for the arm, one referee, one ending rule, one recorder."""

from __future__ import annotations

import numpy as np
import pytest

from controllers.design_cache import grasp_design
from scenarios.runners.trial_loop import (
    GivenReference,
    TrialHooks,
    TrialLoop,
    TrialTiming,
    given_reference_trial,
)
from sim.hand.objects import make_object
from sim.hand.wrist import LIFT_HEIGHT_M
from sim.user.operator import WristMove

DT = 0.01
CAN = make_object("can", mass_kg=0.3, friction=0.5)


class Script:
    """A test person: a reference at each step and arm moves at set times."""

    wrist_tremor_m = 0.0

    def __init__(self, reference_n, moves=(), done_at_s=np.inf) -> None:
        self.reference_n = np.asarray(reference_n, dtype=float)
        self.moves = dict(moves)  # step -> WristMove
        self.done_at_s = done_at_s
        self.done = False

    def act(self, k, scene, setpoint_m):
        self.done = scene.t_s >= self.done_at_s
        return float(self.reference_n[k]), self.moves.get(k)


def _loop(person, limit_s, obj=CAN, **hooks) -> TrialLoop:
    loop = TrialLoop(obj, grasp_design(obj, "pid", DT, None), person, TrialTiming(limit_s, DT),
                     lift_height_m=LIFT_HEIGHT_M, seed=0, hooks=TrialHooks(**hooks))
    loop.run()
    return loop


def test_a_lift_that_leaves_the_object_behind_is_an_attempt_and_the_trial_goes_on() -> None:
    """The empty hand rises and comes back (the can stays on the table), then the person
    squeezes and lifts again: two attempts, held."""
    t = np.arange(700) * DT
    reference = np.where(t >= 2.5, 6.0, 0.0)
    person = Script(reference, moves={50: WristMove(LIFT_HEIGHT_M, 0.6),
                                      150: WristMove(0.0, 0.6),
                                      450: WristMove(LIFT_HEIGHT_M, 0.6)})
    loop = _loop(person, 7.0)
    referee = loop.referee
    assert loop.ended == "duration" and loop.k == 700
    assert referee.attempts == 2 and referee.outcome == "held"
    assert referee.secure_lift_s > 4.5  # the second lift, not the first
    assert loop.info["dropped"]  # the environment saw the can leave the empty hand


def test_the_environment_never_lifts_by_itself() -> None:
    loop = _loop(Script(np.full(400, 6.0)), 4.0)
    assert np.all(loop.traces()["wrist_height_m"] == 0.0)
    assert loop.referee.attempts == 0 and loop.referee.outcome == "not_lifted"


def test_the_ending_rule() -> None:
    t = np.arange(600) * DT
    egg = make_object("egg")
    crushed = _loop(Script(np.full(600, 40.0)), 6.0, obj=egg)
    assert crushed.ended == "crushed" and crushed.k < 600 and crushed.referee.over
    # lifted securely, then the hand opens in the air: the can falls
    fell = given_reference_trial(CAN, grasp_design(CAN, "pid", DT, None),
                                 np.where((t > 0.5) & (t < 3.5), 6.0, 0.0), control_dt_s=DT,
                                 lift_at_s=1.5)
    assert fell.ended == "dropped" and fell.referee.outcome == "dropped" and fell.k < 600
    done = _loop(Script(np.full(600, 6.0), done_at_s=2.0), 6.0)
    assert done.ended == "done" and done.k == 201
    task = _loop(Script(np.full(600, 6.0)), 6.0, until=lambda t_s, info: t_s >= 1.0)
    assert task.ended == "task" and task.k == 101


def test_the_recorder_keeps_what_the_controller_saw_and_computed() -> None:
    loop = _loop(GivenReference(np.full(200, 5.0), lift_at_s=1.0), 2.0,
                 keep_observations=True)
    traces, rec = loop.traces(), loop.recorder
    assert all(v.shape[0] == loop.k for v in traces.values())
    assert len(rec.observations) == len(rec.computed) == loop.k
    # the command delivered at step k is the one computed at step k - 1 (one period late)
    np.testing.assert_array_equal(traces["command"][1:],
                                  np.float32(rec.computed[:-1]).astype(float))
    assert rec.observations[-1].reference_n == 5.0
    assert traces["wrist_height_m"][-1] == pytest.approx(LIFT_HEIGHT_M)


def test_force_hold_on_the_self_locking_hand_keeps_the_grip_through_a_dip_of_the_estimate():
    """A reference with a dip below the can's slip force while it is held, then rest:
    under force on the backdrivable hand the grip follows the dip; under force_hold on the
    self-locking hand the reference and the grip stay, and the hand opens at rest."""
    from scenarios.runners.trial_loop import HandSettings

    t = np.arange(0.0, 5.5, DT)
    ref = np.interp(t, [0.2, 0.7, 3.0, 3.05, 3.8, 3.85, 4.5, 4.55],
                    [0.0, 8.0, 8.0, 2.0, 2.0, 8.0, 8.0, 0.0])
    design = grasp_design(CAN, "pid", DT, None)
    runs = {hand: given_reference_trial(CAN, design, ref, control_dt_s=DT, lift_at_s=1.2,
                                        hand=HandSettings(*hand)).traces()
            for hand in (("backdrivable", "force"), ("self_locking", "force_hold"))}
    held = runs["self_locking", "force_hold"]
    # the reference the loop tracked: the largest since it rose above 0, 0 at rest
    expected = np.where(ref > 0, np.maximum.accumulate(np.where(ref > 0, ref, 0.0)), 0.0)
    n = held["reference_n"].size
    np.testing.assert_allclose(held["reference_n"], expected[:n], atol=1e-12)
    dip = (t[:n] >= 3.2) & (t[:n] <= 3.8)
    before = float(np.median(held["grip_force_n"][(t[:n] >= 2.5) & (t[:n] < 3.0)]))
    assert np.all(held["grip_force_n"][dip] >= 0.95 * before)
    assert held["object_height_m"][dip].min() > 0.5 * LIFT_HEIGHT_M  # still held
    assert held["grip_force_n"][-1] < 0.5  # opened at rest
    follows = runs["backdrivable", "force"]
    m = follows["grip_force_n"].size
    assert np.median(follows["grip_force_n"][dip[:m]]) < 0.5 * before  # the grip dipped
