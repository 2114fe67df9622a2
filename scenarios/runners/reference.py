"""What a trial asks of its user, and the reference their sEMG becomes.

:class:`Task` is what the trial asks (the object's needs, the lift, the hold, the time
limit, the script's goal); :func:`plan_for` turns it into the user's
:class:`~sim.user.operator.Plan` (the scripted intent of the trial, at the level the goal
asks through the calibration's mapping). :class:`ReferenceStream` collects what the
user's sEMG became during a trial (the estimate at each window, the held reference, the
user's true force) for the metrics. The force mapping is explained in
:mod:`scenarios.runners.episode`; the windows, the estimator and the mapping run in
:class:`scenarios.runners.semg_reference.SemgReference`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from controllers.bounds import slip_threshold_n
from scenarios.runners.calibration import Calibration
from scenarios.schema.names import INTACT
from sim.hand.objects import ObjectSpec
from sim.hand.wrist import LIFT_HEIGHT_M
from sim.user.intent import GraspLiftTiming, IntentProfile, grasp_lift_hold
from sim.user.operator import OperatorParams, Plan, grip_aim_n
from sim.user.subjects import VirtualSubject

REST_S = 1.0  # rest before the grasp, s
RAMP_S = 0.5  # ramp to the hold level, s
NOVICE_SAFETY_FACTOR = 1.0 + OperatorParams().novice_margin
"""Grip over the slip force a user aims at without practice (the scripted user's aim)."""


def intended_grip_n(obj: ObjectSpec, safety_factor: float = NOVICE_SAFETY_FACTOR) -> float:
    """Hand grip force a user with ``safety_factor`` aims at for ``obj``, N.

    :func:`sim.user.operator.grip_aim_n` of the object's slip threshold ``m g / (2 mu)``
    and its break force.
    """
    return grip_aim_n(slip_threshold_n(obj.mass_kg, obj.friction), safety_factor,
                      obj.break_force_n)


@dataclass(frozen=True)
class Task:
    """What a trial asks of the user (the :class:`~sim.user.operator.Plan`'s task).

    Attributes
    ----------
    need_n : float or None
        The grip the object needs not to slip, N (``None``: the task gives a
        force target, ``goal_n``, instead).
    goal_n : float
        The hand grip force the script aims at, N (the scripted user's aim and the
        level of every user's scripted intent; a learning user plans their own).
    break_n : float or None
        A fragile object's break force, N.
    lift_height_m : float or None
        How high to lift, m (``None``: hold on the table).
    hold_s : float
        How long to hold before putting the object down, s.
    place : bool
        Put the object down and let go after the hold.
    move_s : float or None
        Duration of the lift and the set-down when the task sets it, s.
    limit_s : float or None
        The trial's time limit, s (``None``: the user's own default,
        :attr:`sim.user.operator.Operator.default_trial_s`).
    sees : bool
        The user sees the hand and the object (``False``: vision occluded,
        :attr:`sim.user.operator.Plan.sees`).
    """

    need_n: float | None
    goal_n: float
    break_n: float | None = None
    lift_height_m: float | None = LIFT_HEIGHT_M
    hold_s: float = 2.0
    place: bool = True
    move_s: float | None = None
    limit_s: float | None = None
    sees: bool = True


def grasp_task(obj: ObjectSpec, *, hold_s: float, lift_height_m: float | None = LIFT_HEIGHT_M,
               place: bool = True, limit_s: float | None = None) -> Task:
    """The task of grasping, lifting and holding ``obj``: its slip and break forces, the
    novice's aim as the script's goal."""
    return Task(need_n=slip_threshold_n(obj.mass_kg, obj.friction),
                goal_n=intended_grip_n(obj), break_n=obj.break_force_n,
                lift_height_m=lift_height_m, hold_s=hold_s, place=place, limit_s=limit_s)


def force_task(goal_n: float, *, limit_s: float) -> Task:
    """The task of holding ``goal_n`` on the table (force matching) until ``limit_s``."""
    return Task(need_n=None, goal_n=float(goal_n), lift_height_m=None, hold_s=float(limit_s),
                place=False, limit_s=float(limit_s))


def reference_from_windows(values_n: np.ndarray, window_t_s: np.ndarray,
                           control_t_s: np.ndarray) -> np.ndarray:
    """Hold each window's value from its end time until the next one (0 before the first)."""
    idx = np.searchsorted(window_t_s, control_t_s + 1e-9, side="right") - 1
    held = np.where(idx >= 0, values_n[np.clip(idx, 0, None)], 0.0)
    return held


@dataclass
class ReferenceStream:
    """The force reference of one trial, at the estimator's and the control rate.

    Attributes
    ----------
    start_s : float or None
        The user's ramp onset (their cue), s; ``None`` when no cue is known (a
        person: the grasp then starts when the reference first reaches 0.5 N).
    window_values_n : ndarray, shape (n_windows,)
        The hand reference at each feature window that ends within the trial's
        limit (estimate mapped to the hand, clipped), N.
    window_dt_s : float
        Estimator update period, s.
    t_s : ndarray, shape (n_steps,)
        Control-rate time, s.
    reference_n, oracle_n : ndarray, shape (n_steps,)
        The held reference, and the same for the user's true grip force (NaN where
        unknown: a person), N.
    """

    start_s: float | None
    window_values_n: np.ndarray
    window_dt_s: float
    t_s: np.ndarray
    reference_n: np.ndarray
    oracle_n: np.ndarray

    def first(self, n_steps: int) -> ReferenceStream:
        """The stream of the first ``n_steps`` control steps (a trial that ended early);
        the windows are kept whole."""
        return replace(self, t_s=self.t_s[:n_steps], reference_n=self.reference_n[:n_steps],
                       oracle_n=self.oracle_n[:n_steps])


def level_per_newton(cal: Calibration, subject: VirtualSubject,
                     hand_force_at_mvc_n: float) -> float:
    """Intent (fraction of MVC) per newton of hand force, through the calibration's mapping."""
    return float(cal.mvc_cal_n / subject.mvc_n / hand_force_at_mvc_n)


def hold_level_for(target_n: float, cal: Calibration, subject: VirtualSubject,
                   hand_force_at_mvc_n: float) -> float:
    """The intent (fraction of MVC) asking for ``target_n`` through the calibration's mapping."""
    return float(np.clip(target_n * level_per_newton(cal, subject, hand_force_at_mvc_n),
                         0.0, 1.0))


def episode_profile(rng: np.random.Generator, hold_level: float, episode_s: float
                    ) -> tuple[IntentProfile, float]:
    """The scripted grasp-lift-hold intent of an episode at 200 Hz, and its ramp onset, s."""
    timing = GraspLiftTiming(rest_s=REST_S, ramp_s=RAMP_S, hold_s=episode_s)
    profile = grasp_lift_hold(rng, fs_hz=200.0, hold_level=hold_level, timing=timing,
                              jitter=0.1)
    return profile, next(t for kind, t in profile.cues if kind == "start")


def plan_for(task: Task, limit_s: float, subject: VirtualSubject, cal: Calibration,
             hand_force_at_mvc_n: float, rng: np.random.Generator) -> tuple[Plan, float]:
    """The user's plan of a trial, and the ramp onset of its script, s.

    The script rests, ramps to the level asking for ``task.goal_n`` through the
    calibration's mapping and holds to ``limit_s`` (timings jittered by 10 %, drawn
    from ``rng``: the same draws the trial's sEMG session then continues from). The
    intact hand's user (``cal.name`` ``intact``) couples grip to load
    (``Plan.couples_load``, :mod:`sim.user.grip_load`).
    """
    hold_level = hold_level_for(task.goal_n, cal, subject, hand_force_at_mvc_n)
    profile, start_s = episode_profile(rng, hold_level, limit_s)
    plan = Plan(intent=profile.intent, fs_hz=profile.fs_hz, hold_level=hold_level,
                goal_n=float(task.goal_n), force_range_n=float(hand_force_at_mvc_n),
                need_n=task.need_n, break_n=task.break_n,
                level_per_n=level_per_newton(cal, subject, hand_force_at_mvc_n),
                lift_height_m=task.lift_height_m, hold_s=task.hold_s, place=task.place,
                move_s=task.move_s, limit_s=float(limit_s),
                open_to_release=getattr(cal, "decoder", None) is not None,
                couples_load=cal.name == INTACT, sees=task.sees)
    return plan, start_s
