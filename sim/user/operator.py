"""The person in the loop: what they perceive of the hand, what they plan, what they remember.

A prosthesis user has no slip reflex through the socket: they see the hand and
the object, feel whatever artificial feedback the prosthesis gives, and move
their own arm. Every perception goes through a *channel* with a delay, a
threshold and noise, and the user's policy reads only the channels, never the
simulator. This module holds what every user model shares:

* :class:`Scene`: the hand and the object after a control step, as plain numbers
  (the trial loop, :mod:`scenarios.runners.trial_loop`, builds it; ``sim.user``
  never imports the hand);
* :class:`Plan`: what a trial asks of the user (the object's needs, the task);
* :class:`WristMove`: a move of the user's own arm, which the trial hands to the
  hand (:meth:`sim.hand.grasp_env.GraspEnv.move_wrist`): every user moves their own
  arm, the scripted one at a set time;
* :class:`TrialMemory`: what the user remembers of a trial, from which they plan
  the next (:mod:`sim.user.belief`);
* the :class:`Operator` protocol.

The models: :class:`sim.user.scripted.ScriptedOperator` follows the script and lifts
at a set time once the grip is established;
:class:`sim.user.reacting.ReactingOperator` sees, feels, corrects, lifts when the grip
looks secure and tries again. Their parameters, with sources, are
:class:`sim.user.operator_params.OperatorParams`. Models and feedback modes are
registered by name (:mod:`sim.user.operators`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from sim.errors import GriploopError
from sim.user.operator_params import OperatorParams, OperatorParamsError

__all__ = ["DelayLine", "FRAGILE_MARGIN", "MIN_GRIP_N", "PACED_TRIAL_S", "Operator",
           "OperatorError", "OperatorParams", "OperatorParamsError", "Plan", "Scene",
           "TrialMemory", "WristMove", "grip_aim_n", "ramp", "started", "take"]

MIN_GRIP_N = 2.0
"""The least grip force a user aims at, N."""
FRAGILE_MARGIN = 0.7
"""A user aims at most at this fraction of a fragile object's break force."""
PACED_TRIAL_S = 15.0
"""The time limit of a trial its user paces, when the task sets none, s (issue 27:
"within a 15 s trial")."""


def grip_aim_n(need_n: float, safety_factor: float, break_n: float | None = None) -> float:
    """The hand grip force a user aims at, N: the one rule every trial and user follows.

    ``safety_factor`` times the grip the object needs not to slip (``need_n``), at
    least :data:`MIN_GRIP_N`, at most :data:`FRAGILE_MARGIN` of a fragile object's
    break force ``break_n``.
    """
    aim = max(safety_factor * need_n, MIN_GRIP_N)
    if break_n is not None:
        aim = min(aim, FRAGILE_MARGIN * break_n)
    return float(aim)


@dataclass(slots=True)
class Scene:
    """The hand and the object at one control step, as plain numbers (what there is to perceive).

    Attributes
    ----------
    t_s : float
        Episode time, s.
    contact : bool
        Both sides of the hand touch the object.
    object_in_hand_m : float
        Height of the object's centre relative to the palm, m (it falls as
        the object slides down in the hand, or stays behind as the hand rises).
    object_height_m : float
        Height of the object's centre above the table, m.
    dropped : bool
        The object is out of the hand now: no digit touches it and it has moved
        away from where the hand held it (not latched: a re-grasp clears it).
    crushed : bool
        The object broke.
    grip_force_n : float
        The hand's grip-force sensor, N (what a force-feedback device codes).
    slip_speed_m_s : float
        The hand's slip sensor, m/s (what a slip-feedback device detects).
    finger_speed_rad_s : float
        How fast the digits move, rad/s (seen: the hand closing, or still).
    touching : bool
        A digit touches the object (one side or both).
    """

    t_s: float
    contact: bool
    object_in_hand_m: float
    object_height_m: float
    dropped: bool
    crushed: bool
    grip_force_n: float
    slip_speed_m_s: float
    finger_speed_rad_s: float = 0.0
    touching: bool = False


@dataclass(frozen=True)
class Plan:
    """What the user sets out to do in one trial.

    Attributes
    ----------
    intent : ndarray, shape (n_samples,)
        The scripted intent of the trial (rest, ramp, hold; fraction of MVC)
        at ``fs_hz``: its onset and shape are the user's, its level is what
        they plan.
    fs_hz : float
        Sampling rate of the intent, Hz.
    hold_level : float
        The hold level of ``intent`` (fraction of MVC): the script's level for
        ``goal_n`` through the calibration.
    goal_n : float
        Hand grip force the script aims at, N.
    force_range_n : float
        Hand force the user commands at their MVC, N (the range a force
        feedback device codes).
    need_n : float or None
        The grip the object needs not to slip, N (the user knows its weight and
        surface from handling it). A user who plans with a safety margin aims
        at it times their margin; ``None``: the task gives a force target,
        ``goal_n``, and the user aims at that.
    break_n : float or None
        A fragile object's break force, N (the user aims at most at
        :data:`FRAGILE_MARGIN` of it).
    level_per_n : float or None
        Contraction (fraction of MVC) per newton of hand force through the
        calibration's mapping: what the prosthesis promises. ``None``: use
        ``hold_level / goal_n``.
    lift_height_m : float or None
        How high the user lifts the object, m; ``None``: no lift (the object is
        held on the table).
    hold_s : float
        How long the user holds the object in the air (or on the table) before
        putting it down, s.
    place : bool
        Put the object down and let go after the hold (the trial then ends).
    move_s : float or None
        Duration of the lift and of the set-down, s, when the task sets it (a
        transport over a partition is one quick movement); ``None``: the user's
        own ``lift_s``.
    limit_s : float
        The trial's time limit, s (the scripted user times their lift from it).
    open_to_release : bool
        The hand opens on a second, open signal (a calibration with open contractions
        and a decoder): the user lets go by contracting to open, not only by relaxing.
    couples_load : bool
        The user plans their grip from the load they expect, as intact hands do (the
        ``intact`` reference: :mod:`sim.user.grip_load`); a user who reacts then aims
        at :meth:`sim.user.belief.ProsthesisBelief.aim_n`'s coupled grip.
    sees : bool
        The user sees the hand and the object. ``False``: vision occluded (Raveh et
        al. 2018's test without vision); a user who reacts then perceives only the
        incidental cue of the hand's digits moving (the motor's sound, or an intact
        hand's proprioception) and their feedback (:mod:`sim.user.reacting`).
    """

    intent: np.ndarray
    fs_hz: float
    hold_level: float
    goal_n: float
    force_range_n: float
    need_n: float | None = None
    break_n: float | None = None
    level_per_n: float | None = None
    lift_height_m: float | None = 0.08
    hold_s: float = 2.0
    place: bool = True
    move_s: float | None = None
    limit_s: float = math.inf
    open_to_release: bool = False
    couples_load: bool = False
    sees: bool = True

    def aim_n(self, margin: float) -> float:
        """The hand grip force a user with safety ``margin`` aims at, N.

        :func:`grip_aim_n` of ``need_n`` with safety factor ``1 + margin``;
        ``goal_n`` when the task gives a force target (``need_n`` None).
        """
        if self.need_n is None:
            return float(self.goal_n)
        return grip_aim_n(self.need_n, 1.0 + margin, self.break_n)

    def level_of(self, force_n: float) -> float:
        """The contraction the calibration's mapping asks for ``force_n`` of hand force."""
        per_n = self.level_per_n if self.level_per_n is not None else (
            self.hold_level / self.goal_n if self.goal_n > 0 else 0.0)
        return float(per_n * force_n)


@dataclass(frozen=True)
class WristMove:
    """A move of the user's arm: to ``height_m`` (m above the approach pose) in ``duration_s``.

    ``path`` is ``min_jerk`` (a point-to-point movement) or ``follow`` (one segment of
    a measured arm's path, ``duration_s`` its time constant).
    """

    height_m: float
    duration_s: float
    path: str = "min_jerk"


@dataclass
class TrialMemory:
    """What the user remembers of a trial (for the next one's plan).

    Attributes
    ----------
    planned_level, final_level : float
        The hold level planned and the one reached after corrections.
    aim_n : float or None
        The hand grip force the user aimed at when they planned the trial, N
        (``None``: the script's goal).
    slip_seen, drop_seen, break_seen : bool
        What the user perceived during the trial.
    corrections : int
        Corrections made (squeezes after a slip and before a new attempt).
    attempts : int
        Lifts the user started (0 for a task without a lift).
    """

    planned_level: float
    final_level: float
    slip_seen: bool = False
    drop_seen: bool = False
    break_seen: bool = False
    corrections: int = 0
    attempts: int = 0
    aim_n: float | None = None


class Operator(Protocol):
    """A user model: their intent and their arm (registered in :mod:`sim.user.operators`).

    ``start`` begins a trial; ``perceive`` is called once per control step, in
    order, with the scene after the previous step (the user decides there);
    ``intent`` returns the next ``n_samples`` of intent (fraction of MVC) at the
    plan's rate, for sample times at or before the last perceived step's time
    (the trial asks when a feature window needs them, so a decision never
    changes samples before it); ``wrist_move`` returns the arm move decided at
    the last ``perceive`` (each once; ``None``: the arm stays), the only route by
    which the wrist moves; ``finish`` ends the trial (what the user learnt feeds
    the next ``start``). ``open_intent`` returns the open intent (0..1 of the user's
    largest opening) of the same samples the last ``intent`` call gave: the second signal
    of a hand that opens on one (``plan.open_to_release``); zeros for a user who never
    opens. ``corrections`` counts the corrections of the current
    trial and ``correction_times`` lists when they were decided (episode time, s).

    The rest describes the user to the trial: ``done`` (the trial is over for
    the user, who put the object down and let go), ``belief`` (what a user who
    learns believes of the prosthesis, :class:`~sim.user.belief.ProsthesisBelief`;
    ``None`` for one who does not), ``phase_log`` (``(t_s, phase)`` when each
    phase of the trial began; empty for a user without phases), ``reacts``
    (whether the intent depends on what the user perceives; one who does not
    react can have their sEMG recorded before the trial, with any generator) and
    ``default_trial_s`` (the trial's time limit when the task sets none, s).

    :func:`sim.user.operators.make_operator` completes a registered model that
    lacks these: its arm is then the scripted user's (:class:`sim.user.scripted.ScriptedArm`:
    a lift at a set time once the grip is established).
    """

    name: str
    corrections: int
    correction_times: list[float]
    done: bool
    belief: Any
    phase_log: list[tuple[float, str]]
    reacts: bool
    default_trial_s: float

    def start(self, plan: Plan, *, control_dt_s: float, rng: np.random.Generator) -> None: ...

    def perceive(self, scene: Scene) -> None: ...

    def intent(self, n_samples: int) -> np.ndarray: ...

    def open_intent(self, n_samples: int) -> np.ndarray: ...

    def wrist_move(self) -> WristMove | None: ...

    def finish(self) -> TrialMemory: ...


class OperatorError(GriploopError, ValueError):
    """An operator used out of order or with a feedback it cannot take."""


def started(plan: Plan | None) -> Plan:
    """``plan``, or :class:`OperatorError` when the trial has not started."""
    if plan is None:
        raise OperatorError("operator used before start(plan)")
    return plan


def take(x: np.ndarray, i0: int, n: int) -> np.ndarray:
    """``x[i0:i0+n]``, padded with its last value past the end."""
    out = x[i0:i0 + n]
    if out.size < n:
        out = np.concatenate([out, np.full(n - out.size, x[-1] if x.size else 0.0)])
    return out


def ramp(dt_s: Any, lo: float, hi: float, rise_s: float) -> Any:
    """A raised-cosine move from ``lo`` to ``hi`` over ``rise_s``, ``dt_s`` after it began."""
    x = np.clip(np.asarray(dt_s, dtype=float) / rise_s, 0.0, 1.0) if rise_s > 0 else \
        np.ones_like(np.asarray(dt_s, dtype=float))
    out = lo + (hi - lo) * (0.5 - 0.5 * np.cos(np.pi * x))
    return out if np.ndim(out) else float(out)


class DelayLine:
    """A delay of ``steps`` control periods: what went in ``steps`` calls ago (or ``None``)."""

    def __init__(self, steps: int) -> None:
        self._steps = max(int(steps), 0)
        self._buffer: list[Any] = [None] * max(self._steps, 1)
        self._i = 0

    def push(self, value: Any) -> Any:
        """Add the newest value; return the one from ``steps`` calls ago (``None`` before)."""
        if self._steps == 0:
            return value
        buf, i = self._buffer, self._i
        old = buf[i]
        buf[i] = value
        self._i = i + 1 if i + 1 < self._steps else 0
        return old
