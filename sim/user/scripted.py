"""The user who follows the script: its intent, whatever the hand does, and a timed lift.

The scripted user is griploop's oldest user and the paper's calibration session: they
rest, ramp to the planned level and hold it, whatever they see. Their arm
(:class:`ScriptedArm`) lifts the object at a set time, ``limit - hold - lift`` of the
trial (so that the object is in the air for the plan's hold before the trial ends),
but only once the grip is established: both sides of the hand touch the object with
at least :data:`ESTABLISHED_GRIP_N`. A grip that never forms is never lifted. They
hold the object in the air until the trial ends (no set-down).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sim.user.operator import (
    OperatorError,
    OperatorParams,
    Plan,
    Scene,
    TrialMemory,
    WristMove,
    started,
    take,
)

ESTABLISHED_GRIP_N = 1.0
"""Grip force with both sides touching that counts as established before the scripted
lift, N (as the hand's own schedule, :class:`sim.hand.wrist.WristSchedule`)."""
CLOSING_S = 0.3
"""The scripted lift comes at least this long after the script reaches its level, s:
time for the hand to close on the object."""
SCRIPTED_TRIAL_S = 6.0
"""The scripted user's trial length when the task sets none, s (the lift comes at a set
time before its end)."""


class ScriptedArm:
    """A lift at a set time once the grip is established, then a hold (module notes).

    Parameters
    ----------
    lift_s : float
        Duration of the lift, s (the plan's ``move_s`` when it sets one).

    Attributes
    ----------
    lift_at_s : float
        The earliest lift of the current trial, s (``inf``: the plan has no lift).
    lifted_s : float or None
        When the lift started, s.
    """

    def __init__(self, lift_s: float) -> None:
        self.lift_s = float(lift_s)
        self.lifted_s: float | None = None
        self._move: WristMove | None = None
        self.time_lift(math.inf, 0.0)

    def start(self, plan: Plan) -> None:
        """Time the lift of ``plan``: ``limit_s - hold_s - lift``.

        Raises
        ------
        OperatorError
            The lift would come before the script has reached its level and the hand
            has had :data:`CLOSING_S` to close.
        """
        if plan.lift_height_m is None or not math.isfinite(plan.limit_s):
            self.time_lift(math.inf, 0.0)
            return
        lift_s = self.lift_s if plan.move_s is None else float(plan.move_s)
        self.time_lift(plan.limit_s - plan.hold_s - lift_s, float(plan.lift_height_m), lift_s)
        level = np.flatnonzero(plan.intent >= 0.99 * plan.hold_level) if plan.hold_level > 0 \
            else np.zeros(1, dtype=int)
        ready_s = float(level[0] / plan.fs_hz) if level.size else math.inf
        if self.lift_at_s < ready_s + CLOSING_S:
            raise OperatorError(
                f"the scripted lift at limit {plan.limit_s:g} s - hold {plan.hold_s:g} s - lift "
                f"{lift_s:g} s = {self.lift_at_s:.2f} s leaves no time to grasp: the script "
                f"reaches its level at {ready_s:.2f} s and the hand needs {CLOSING_S:g} s to "
                "close; expected a longer trial or a shorter hold")

    def time_lift(self, at_s: float, height_m: float, duration_s: float | None = None) -> None:
        """Lift to ``height_m`` in ``duration_s`` (default ``lift_s``) at ``at_s`` or later,
        once the grip is established (``inf``: never); nothing lifted yet."""
        self.lift_at_s, self._height_m = float(at_s), float(height_m)
        self._duration_s = self.lift_s if duration_s is None else float(duration_s)
        self.lifted_s, self._move = None, None

    def perceive(self, scene: Scene) -> None:
        """Lift at the set time once the grip is established."""
        if (self.lifted_s is None and scene.t_s >= self.lift_at_s - 1e-9 and scene.contact
                and scene.grip_force_n >= ESTABLISHED_GRIP_N):
            self.lifted_s = scene.t_s
            self._move = WristMove(self._height_m, self._duration_s)

    def wrist_move(self) -> WristMove | None:
        """The lift, once, at the step it was decided."""
        move, self._move = self._move, None
        return move


class ScriptedOperator:
    """The user who follows the script: the plan's intent, whatever the hand does.

    Takes no feedback (``feedback`` must be ``None`` or ``"none"``); makes no
    corrections; lifts at a set time once the grip is established
    (:class:`ScriptedArm`) and holds until the trial ends. The paper's calibration
    session is this user.
    """

    name = "scripted"
    reacts = False
    default_trial_s = SCRIPTED_TRIAL_S
    belief = None
    done = False

    def __init__(self, params: OperatorParams | None = None, feedback: Any = None) -> None:
        if feedback is not None and getattr(feedback, "name", feedback) != "none":
            name = getattr(feedback, "name", feedback)
            raise OperatorError(
                f"feedback applies to the reacting user only: the scripted user takes "
                f"feedback none (found {name})")
        self.params = params or OperatorParams()
        self.arm = ScriptedArm(self.params.lift_s)
        self.corrections = 0
        self.correction_times: list[float] = []
        self.phase_log: list[tuple[float, str]] = []
        self._plan: Plan | None = None
        self._n = 0

    def start(self, plan: Plan, *, control_dt_s: float, rng: np.random.Generator) -> None:
        """Begin a trial (the scripted user ignores ``rng``); time the lift."""
        self.arm.start(plan)
        self._plan, self._n, self.corrections = plan, 0, 0

    def perceive(self, scene: Scene) -> None:
        """The arm watches for the established grip; the intent ignores everything."""
        self.arm.perceive(scene)

    def intent(self, n_samples: int) -> np.ndarray:
        """The plan's next ``n_samples`` of intent."""
        plan = started(self._plan)
        i0 = self._n
        self._n += n_samples
        return take(plan.intent, i0, n_samples)

    def open_intent(self, n_samples: int) -> np.ndarray:
        """The scripted user never opens: zeros."""
        return np.zeros(int(n_samples))

    def wrist_move(self) -> WristMove | None:
        """The scripted lift, at the step it starts."""
        return self.arm.wrist_move()

    def finish(self) -> TrialMemory:
        """The trial as planned (nothing learnt)."""
        plan = started(self._plan)
        return TrialMemory(plan.hold_level, plan.hold_level, aim_n=plan.goal_n)
