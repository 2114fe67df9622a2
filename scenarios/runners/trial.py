"""One closed-loop trial: a calibrated user, the designed controller and the MuJoCo hand.

:func:`run_trial` runs one grasp of an object and returns its traces. Two users:

* the **scripted** user (:class:`sim.user.scripted.ScriptedOperator`, the class
  itself) runs the batch path: the whole reference is computed before the physics,
  and the wrist follows a :class:`~sim.hand.wrist.WristSchedule` (lift at a set
  time once the grip is established);
* any other user runs in the loop (:class:`~scenarios.runners.operator_loop.LiveUser`,
  causal sEMG). A user who moves their own arm (an operator with ``wrist_move``,
  :class:`sim.user.reacting.ReactingOperator`) gets a commanded wrist: the hand
  carries out each move they decide, the episode goes on when an object stays
  behind (they try again), and the trial ends when they are done, when the object
  breaks or falls after a secure lift, or at the time limit.
  :class:`~scenarios.runners.trial_outcome.TrialReferee` judges it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.design import ControllerDesign
from controllers.drive import HandLoop
from scenarios.runners.calibration import Calibration
from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
from scenarios.runners.operator_loop import STEP_MS, WINDOW_MS, LiveUser, scene_from_info
from scenarios.runners.reference import (
    RAMP_S,
    REST_S,
    ReferenceStream,
    Task,
    live_stream,
    live_user,
    scripted_reference,
)
from scenarios.runners.trial_outcome import TrialReferee
from sim.hand.grasp_env import GraspEnv, WristSchedule
from sim.hand.objects import ObjectSpec
from sim.user.operator import Operator
from sim.user.scripted import ScriptedOperator
from sim.user.subjects import VirtualSubject

LIFT_DURATION_S = 0.6
"""Duration of the scripted schedule's lift, s."""
SCRIPTED_EPISODE_S = 6.0
"""Default length of a scripted user's episode, s (the lift comes at a set time)."""
TRIAL_LIMIT_S = 15.0
"""Default time limit of a trial paced by its user, s (issue 27: "within a 15 s trial")."""


def paces_itself(operator: Operator) -> bool:
    """Whether ``operator`` moves its own arm (lifts when it chooses, tries again)."""
    return callable(getattr(operator, "wrist_move", None))


def default_episode_s(operator: Operator) -> float:
    """An episode's length when none is given: a self-paced trial's limit, or the script's."""
    return TRIAL_LIMIT_S if paces_itself(operator) else SCRIPTED_EPISODE_S


def lift_time_s(episode_s: float, hold_s: float) -> float:
    """When the scripted wrist starts lifting, s: ``episode_s - hold_s`` less the lift's duration.

    Raises
    ------
    UnsupportedScenarioError
        That leaves no time to grasp (rest, ramp and closing) before the lift.
    """
    lift_after_s = episode_s - hold_s - LIFT_DURATION_S
    if lift_after_s < REST_S * 1.1 + RAMP_S + 0.3:
        raise UnsupportedScenarioError(
            f"episode_s - hold_s - {LIFT_DURATION_S} s lift = {lift_after_s:.2f} s leaves no time "
            f"to grasp before lifting: needs at least {REST_S * 1.1 + RAMP_S + 0.3:.2f} s"
        )
    return lift_after_s


#: The timing fields of a row, s (wall time in each part of the loop); ``run_trial`` adds
#: to a dict of these.
TIMING_KEYS = ("t_semg_s", "t_features_s", "t_estimator_s", "t_operator_s", "t_controller_s",
               "t_physics_s")


@dataclass
class Trial:
    """One closed-loop trial: the traces, how it ended, and the reference it ran on.

    Attributes
    ----------
    traces : dict of ndarray
        :func:`closed_loop`'s traces (plus ``user_intent`` for a user in the loop).
    failure : str or None
        MuJoCo's warning if the physics diverged.
    info : dict
        The environment's last ``info``.
    stream : ReferenceStream
        The reference and the user's true force at the control rate (for the metrics).
    referee : TrialReferee or None
        The ground truth of a trial the user paced (None on the scripted schedule).
    phases : list of (float, str)
        When the user's phases began (a self-paced user's ``phase_log``), s.
    attempts : int or None
        Lifts the user started (None on the scripted schedule).
    """

    traces: dict[str, np.ndarray]
    failure: str | None
    info: dict[str, Any]
    stream: ReferenceStream
    referee: TrialReferee | None = None
    phases: list[tuple[float, str]] | None = None
    attempts: int | None = None

    def raise_if_diverged(self, what: str = "") -> None:
        """Raise :class:`~scenarios.runners.dispatch.DivergedError` if the physics diverged.

        The message names MuJoCo's warning and the time, after ``what`` (e.g.
        ``"practice lift: "``).
        """
        if self.failure is not None:
            raise DivergedError(f"{what}physics diverged at t = {self.info['time_s']:.3f} s: "
                                f"{self.failure}")


def run_trial(subject: VirtualSubject, obj: ObjectSpec, cal: Calibration,
              design: ControllerDesign, operator: Operator, *, goal_n: float,
              seeds: tuple[np.random.SeedSequence, np.random.SeedSequence,
                           np.random.SeedSequence],
              generator: str, episode_s: float, lift_after_s: float, control_dt_s: float,
              hand_force_at_mvc_n: float, timings: dict[str, float],
              record_frames: bool = False, hold_level: float | None = None,
              task: Task | None = None, window_ms: float = WINDOW_MS, step_ms: float = STEP_MS,
              load: Callable[[float, Mapping[str, Any]], float] | None = None,
              schedule: WristSchedule | None = None,
              until: Callable[[float, Mapping[str, Any]], bool] | None = None) -> Trial:
    """One grasp of ``obj`` by a calibrated user, scripted or in the loop (module notes).

    Parameters
    ----------
    goal_n : float
        Hand grip force the script aims at, N.
    seeds : (SeedSequence, SeedSequence, SeedSequence)
        The sEMG session (profile and noise), the environment and the operator.
    episode_s : float
        The episode's length: the time limit of a trial the user paces, s.
    lift_after_s : float
        The scripted wrist's earliest lift, s.
    hold_level : float, optional
        The scripted hold level (default: ``goal_n`` through the calibration).
    task : Task, optional
        What the user is asked to do (the object's needs, the lift); required
        for a user who paces the trial to lift.
    window_ms, step_ms : float
        The feature window and its increment, ms.
    load, schedule, until
        See :func:`closed_loop`.

    Raises
    ------
    UnsupportedScenarioError
        A user in the loop with an sEMG generator that cannot run causally.
    """
    episode_seq, env_seq, operator_seq = seeds
    if type(operator) is ScriptedOperator and hold_level is None:  # not a subclass: it may act
        stream = scripted_reference(subject, cal, goal_n, np.random.default_rng(episode_seq),
                                   generator=generator, episode_s=episode_s,
                                   control_dt_s=control_dt_s,
                                   hand_force_at_mvc_n=hand_force_at_mvc_n, timings=timings,
                                   window_ms=window_ms, step_ms=step_ms)
        traces, failure, info = closed_loop(obj, design, stream.reference_n, stream.t_s,
                                            control_dt_s, episode_s, lift_after_s, env_seq,
                                            timings, record_frames, load=load,
                                            schedule=schedule, until=until)
        return Trial(traces, failure, info, stream)
    person, start_s = live_user(subject, cal, operator, goal_n, np.random.default_rng(episode_seq),
                                np.random.default_rng(operator_seq), generator=generator,
                                episode_s=episode_s, control_dt_s=control_dt_s,
                                hand_force_at_mvc_n=hand_force_at_mvc_n, hold_level=hold_level,
                                task=task, window_ms=window_ms, step_ms=step_ms)
    t_ctrl = np.arange(int(round(episode_s / control_dt_s))) * control_dt_s
    reference = np.zeros(t_ctrl.size)
    referee = None
    if paces_itself(operator) and task is not None and task.lift_height_m is not None:
        referee = TrialReferee(task.lift_height_m)
    traces, failure, info = closed_loop(obj, design, reference, t_ctrl, control_dt_s, episode_s,
                                        lift_after_s, env_seq, timings, record_frames,
                                        user=person, load=load, schedule=schedule, until=until,
                                        referee=referee)
    person.intent_until(int(round(t_ctrl.size * control_dt_s * person.fs_hz)))
    stream = live_stream(person, start_s, t_ctrl, reference, episode_s, timings)
    traces["user_intent"] = person.intent[
        np.minimum((traces["t_s"] * person.fs_hz).round().astype(int), person.n_samples - 1)]
    self_paced = paces_itself(operator)
    phases = list(operator.phase_log) if self_paced else None  # type: ignore[attr-defined]
    attempts = int(operator.attempts) if self_paced else None  # type: ignore[attr-defined]
    operator.finish()
    return Trial(traces, failure, info, stream, referee, phases, attempts)


def closed_loop(obj: ObjectSpec, design: ControllerDesign, reference: np.ndarray | None,
                t_ctrl: np.ndarray, control_dt_s: float, episode_s: float,
                lift_after_s: float, env_seq: np.random.SeedSequence,
                timings: dict[str, float], record_frames: bool, *,
                user: LiveUser | None = None,
                load: Callable[[float, Mapping[str, Any]], float] | None = None,
                schedule: WristSchedule | None = None,
                until: Callable[[float, Mapping[str, Any]], bool] | None = None,
                referee: TrialReferee | None = None,
                ) -> tuple[dict[str, np.ndarray], str | None, dict[str, Any]]:
    """Drive GraspEnv with the designed controller; returns traces, failure, last info.

    Parameters
    ----------
    reference : ndarray, shape (n_steps,) or None
        The reference of a scripted user, computed before the physics; ``None``
        with ``user``.
    t_ctrl : ndarray, shape (n_steps,)
        Control-step times, s.
    user : LiveUser, optional
        A user in the loop: the reference of step k is ``user.step(k, scene)``
        with the scene after step k - 1. If the episode ends early (a drop, a
        crush, the user done), the user goes on to ``n_steps`` seeing the last
        scene, so the reference covers the episode as a scripted user's does.
        If the user moves their own arm, the hand's wrist is commanded: each
        move they decide at step k starts at step k.
    load : callable, optional
        ``load(t_s, info) -> N``: a load hung on the object before the step at
        ``t_s`` (:meth:`sim.hand.grasp_env.GraspEnv.set_object_load`).
    schedule : WristSchedule, optional
        The scripted wrist's schedule (default: lift after ``lift_after_s``).
    until : callable, optional
        ``until(t_s, info) -> bool``: end the episode after the step at ``t_s``
        when true (a task that has its answer).
    referee : TrialReferee, optional
        Judges a trial the user paces after every step; the episode ends when
        it is over (a crush, a fall after the lift) or when the user is done.
    """
    operator = user.operator if user is not None else None
    commanded = operator is not None and paces_itself(operator)
    schedule = schedule or WristSchedule(lift_after_s=lift_after_s,
                                         lift_duration_s=LIFT_DURATION_S)
    env = GraspEnv(obj, 0.0, control_dt_s=control_dt_s, episode_s=episode_s,
                   schedule=schedule, render_mode="rgb_array" if record_frames else None,
                   wrist="commanded" if commanded else "scheduled",
                   terminate_on_drop=not commanded)
    n = t_ctrl.size
    reference = np.zeros(n) if reference is None else reference
    rec = _Recorder(n, record_frames, every=max(1, int(round(0.04 / control_dt_s))))
    loop = HandLoop(env, design.controller)
    load_n = 0.0
    try:
        info = loop.reset(seed=int(env_seq.generate_state(1)[0]))
        k = 0
        for k in range(n):
            t_k = float(t_ctrl[k])
            if user is not None:
                reference[k] = user.step(k, scene_from_info(t_k, info))
                move = operator.wrist_move() if commanded else None  # type: ignore[union-attr]
                if move is not None:
                    env.move_wrist(move.height_m, move.duration_s)
            if load is not None:
                new_load = float(load(t_k, info))
                if new_load != load_n:
                    env.set_object_load(new_load)
                    load_n = new_load
                rec.loads[k] = load_n
            ref = float(reference[k])
            env.set_reference(ref)
            _, command, done = loop.step(ref)
            info = loop.info
            rec.record(k, info, command, max(ref, design.core.last_reference_n), env)
            if referee is not None:
                referee.update(t_k, info)
                done = done or referee.over or operator.done  # type: ignore[union-attr]
            if done or (until is not None and until(t_k, info)):
                break
        k_end = k + 1
        if user is not None:  # the user goes on, seeing the last scene (module notes)
            for j in range(k_end, n):
                reference[j] = user.step(j, scene_from_info(float(t_ctrl[j]), info))
    finally:
        env.close()
    timings["t_controller_s"] += loop.controller_s
    timings["t_physics_s"] += loop.physics_s
    return rec.traces(t_ctrl, reference, k_end, load is not None), info.get("failure"), info


class _Recorder:
    """The traces of :func:`closed_loop`, filled step by step."""

    def __init__(self, n: int, record_frames: bool, every: int) -> None:
        self.grip, self.command, self.height = np.zeros(n), np.zeros(n), np.zeros(n)
        self.slip, self.wrist, self.tracked, self.loads = (np.zeros(n), np.zeros(n),
                                                           np.zeros(n), np.zeros(n))
        self.both = np.zeros(n, dtype=bool)
        self.frames: list[np.ndarray] | None = [] if record_frames else None
        self.every = every

    def record(self, k: int, info: Mapping[str, Any], command: float, tracked: float,
               env: GraspEnv) -> None:
        """The readings after step ``k``."""
        self.grip[k] = info["grip_force_n"]
        self.command[k] = command
        self.height[k], self.slip[k] = info["object_height_m"], info["slip_speed_m_s"]
        self.wrist[k] = info["wrist_height_m"]
        self.both[k] = info["thumb_contact"] and info["finger_contact"]
        self.tracked[k] = tracked
        if self.frames is not None and k % self.every == 0:
            self.frames.append(env.render())

    def traces(self, t_ctrl: np.ndarray, reference: np.ndarray, k_end: int,
               with_load: bool) -> dict[str, np.ndarray]:
        """The first ``k_end`` steps of every trace."""
        out = {"t_s": t_ctrl[:k_end], "reference_n": reference[:k_end],
               "grip_force_n": self.grip[:k_end], "command": self.command[:k_end],
               "object_height_m": self.height[:k_end], "slip_speed_m_s": self.slip[:k_end],
               "wrist_height_m": self.wrist[:k_end], "both_sides": self.both[:k_end],
               "tracked_reference_n": self.tracked[:k_end]}
        if with_load:
            out["object_load_n"] = self.loads[:k_end]
        if self.frames is not None:
            out["frames"] = np.stack(self.frames)
        return out
