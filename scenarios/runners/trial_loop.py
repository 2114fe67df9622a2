"""One control step of a grasp, for every trial: simulated, practised, benchmarked, replayed, live.

A trial joins a scene (the hand and its object, :class:`~sim.hand.grasp_env.GraspEnv`),
a person (their intent and their arm), the sEMG window and the estimator that turn the
person's samples into the hand's reference, the controller
(:class:`~controllers.drive.HandLoop`), a recorder (:class:`TrialRecorder`) and a referee
(:class:`~scenarios.runners.trial_outcome.TrialReferee`). :class:`TrialLoop` owns one
control step of it and the rule that ends the trial::

    the scene after step k-1 --> person.act(k, scene, wrist set-point)
        --> the hand reference (N) and a move of the arm (or none)
        --> the task's load on the object --> controller --> GraspEnv.step
        --> recorder, referee --> the ending rule

The person is a :class:`Person`: a virtual subject and their operator
(:class:`scenarios.runners.person.VirtualPerson`), a recording with its forearm's pitch
(:class:`scenarios.live.recorded.RecordedPerson`) or a person streaming over LSL
(:class:`scenarios.live.session.LiveGrasp`). Trials differ only there, in the clock that
calls :meth:`TrialLoop.step` (a loop over the steps offline; the arrival of samples
live) and in what they publish after each step.

**The arm** has one route: whatever the person decides (:class:`~sim.user.operator.WristMove`)
moves the hand's commanded wrist at the step it is decided. The environment never
lifts by itself.

**The ending rule**: the trial ends after the step where the referee has its answer
(crushed; fell after a secure lift), the person is done, the task's own rule
(``until``) says so, the physics diverged, or the time limit is reached. Nothing else
ends it: a lift that leaves the object behind is an attempt, and the person may try
again.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from controllers.drive import HandLoop
from controllers.paradigms import (
    FULL_RANGE,
    DecoderMissingError,
    make_paradigm,
    needs_decoder,
    uses_decoder,
)
from controllers.reflex import AUTO_GRIP
from scenarios.runners.trial_outcome import TrialReferee
from sim.hand.drive import make_drive
from sim.hand.grasp_env import GraspEnv, GraspTask, HandSpec
from sim.hand.objects import ObjectSpec
from sim.hand.wrist import LIFT_HEIGHT_M
from sim.user.operator import Scene, WristMove
from sim.user.scripted import ScriptedArm

#: Why a trial ended (:attr:`TrialLoop.ended`).
ENDINGS = ("crushed", "dropped", "done", "task", "diverged", "duration")


def scene_from_info(t_s: float, info: Mapping[str, Any]) -> Scene:
    """What there is to perceive after a control step, from the environment's ``info``."""
    # positional and unconverted: GraspEnv's info holds plain floats and bools already,
    # and this runs at every control step
    return Scene(t_s, info["thumb_contact"] and info["finger_contact"],
                 info["object_in_palm_z_m"], info["object_height_m"],
                 info["object_out_of_hand"], info["crushed"], info["grip_force_n"],
                 info["slip_speed_m_s"], abs(info["finger_velocity_rad_s"]),
                 info["thumb_contact"] or info["finger_contact"])


class Person(Protocol):
    """Who drives a trial: the hand's reference from their sEMG, and their arm.

    ``act(k, scene, setpoint_m)`` is called once per control step ``k`` with the scene
    after step ``k - 1`` and the wrist's set-point then (m); it returns the hand's
    reference for step ``k`` (N) and the arm's move decided now (or ``None``). ``done``
    says the person has finished the task. ``wrist_tremor_m`` is how much the person's
    wrist moves when held still (0 for a virtual arm; a measured arm trembles): the
    in-air hold ends when the wrist comes down by more than it. ``decoded`` is the
    latest window's open and close signals (:class:`controllers.paradigms.Decoded`), or
    ``None`` when the person's calibration has no decoder (a person may leave it out).
    """

    done: bool
    wrist_tremor_m: float

    def act(self, k: int, scene: Scene, setpoint_m: float) -> tuple[float, WristMove | None]: ...


class GivenReference:
    """A person who asks for a given reference and lifts at a set time once the grip is
    established (:class:`sim.user.scripted.ScriptedArm`): a controller's own trial, with
    no sEMG in it (controller tests and benchmarks).

    Parameters
    ----------
    reference_n : ndarray, shape (n_steps,)
        The reference at each control step, N.
    lift_at_s : float
        The earliest lift, s (``inf``: none).
    lift_height_m, lift_s : float
        The lift's height, m, and duration, s.
    """

    done = False
    wrist_tremor_m = 0.0

    def __init__(self, reference_n: np.ndarray, *, lift_at_s: float = math.inf,
                 lift_height_m: float = LIFT_HEIGHT_M, lift_s: float = 0.6) -> None:
        self.reference_n = np.asarray(reference_n, dtype=float)
        self.arm = ScriptedArm(lift_s)
        self.arm.time_lift(lift_at_s, lift_height_m)

    def act(self, k: int, scene: Scene, setpoint_m: float) -> tuple[float, WristMove | None]:
        """The given reference at step ``k``, and the lift once it is due."""
        self.arm.perceive(scene)
        return float(self.reference_n[k]), self.arm.wrist_move()


def given_reference_trial(obj: ObjectSpec, design: Any, reference_n: np.ndarray, *,
                          control_dt_s: float, lift_at_s: float = math.inf,
                          seed: int = 0, hand: HandSettings | None = None) -> TrialLoop:
    """Run a trial of :class:`GivenReference` over ``reference_n`` (its length sets the limit)
    on ``hand`` (default today's: :data:`DEFAULT_HAND`); the finished :class:`TrialLoop`
    (its ``traces()``, ``info``, ``failure``)."""
    loop = TrialLoop(obj, design, GivenReference(reference_n, lift_at_s=lift_at_s),
                     TrialTiming(len(reference_n) * control_dt_s, control_dt_s),
                     lift_height_m=LIFT_HEIGHT_M, seed=seed, hand=hand or DEFAULT_HAND)
    loop.run()
    return loop


@dataclass(frozen=True)
class HandSettings:
    """The prosthetic hand's own settings beside its controller.

    Attributes
    ----------
    drive : str
        The transmission (:mod:`sim.hand.drive`): ``backdrivable`` or ``self_locking``.
    paradigm : str
        How the reference follows the estimate (:mod:`controllers.paradigms`): ``force``,
        ``force_hold`` or ``velocity``.
    auto_grip : bool
        The hand's own slip response: the slip reflex around whatever controller runs
        (:data:`controllers.reflex.AUTO_GRIP`).
    decoder : str or None
        The open/close decoder (:mod:`estimation.decoding`: ``two_site`` or ``pattern``)
        the calibration fits on open contractions too; ``None``: none, unless the
        paradigm needs one (``velocity``), which then gets the default
        (:attr:`effective_decoder`).
    human : bool
        The digits are the intact hand's (:mod:`sim.hand.human`: pre-shaped to the object,
        closing in human time), not the prosthesis's: set for the ``intact`` reference
        (:func:`scenarios.runners.person.hand_for`); its drive is then backdrivable.
    """

    drive: str = "backdrivable"
    paradigm: str = "force"
    auto_grip: bool = False
    decoder: str | None = None
    human: bool = False

    def env_specs(self, limit_s: float) -> tuple[HandSpec, GraspTask]:
        """The simulated hand and the episode of a trial of ``limit_s`` on this hand."""
        if not self.human:
            return HandSpec(drive=self.drive), GraspTask(episode_s=limit_s)
        from controllers.design_spec import DesignSpec
        from sim.hand.human import human_hand, human_task
        return human_hand(DesignSpec().closing_command), human_task(limit_s)

    @property
    def effective_decoder(self) -> str | None:
        """The decoder the calibration fits: the one asked for, else the default
        (:data:`estimation.decoding.DEFAULT_DECODER`) when the paradigm needs one."""
        if self.decoder is not None:
            return self.decoder
        if needs_decoder(self.paradigm):
            from estimation.decoding import DEFAULT_DECODER
            return DEFAULT_DECODER
        return None

    def check(self) -> HandSettings:
        """``self``, or a one-line error naming the registered drives, paradigms or
        decoders.

        Raises
        ------
        sim.hand.drive.UnknownDriveError, controllers.paradigms.UnknownParadigmError,
        estimation.decoding.UnknownDecoderError
        """
        make_drive(self.drive)
        make_paradigm(self.paradigm)
        if self.decoder is not None:
            from estimation.decoding import make_decoder
            make_decoder(self.decoder)
        return self

    def controller_spec(self, spec: Mapping[str, Any] | None) -> dict[str, Any] | None:
        """The controller specification with the hand's slip response when ``auto_grip``
        (a specification that sets its own ``slip_reflex`` keeps it: one reflex)."""
        if not self.auto_grip or (spec and spec.get("slip_reflex")):
            return None if spec is None else dict(spec)
        return {**dict(spec or {}), "slip_reflex": dict(AUTO_GRIP)}

    def fields(self) -> dict[str, Any]:
        """The settings as a row's columns (``decoder`` only when there is one)."""
        out = {"paradigm": self.paradigm, "drive": self.drive, "auto_grip": self.auto_grip}
        decoder = self.effective_decoder
        if decoder is not None:
            out["decoder"] = decoder
        return out


DEFAULT_HAND = HandSettings()
"""Today's hand: backdrivable, the force paradigm, no slip response of its own."""


@dataclass(frozen=True)
class Frames:
    """What a trial keeps of the hand for a video: every ``every_s`` of trial time, an RGB
    frame (``kind="rgb"``, rendered now) or the state to render later (``"state"``:
    ``(qpos, crushed)``)."""

    every_s: float = 0.04
    kind: str = "rgb"


@dataclass(frozen=True)
class TrialHooks:
    """What a task adds to a trial, and what a trial keeps beside its traces.

    Attributes
    ----------
    load : callable, optional
        ``load(t_s, info) -> N``: a load hung on the object before the step at ``t_s``
        (:meth:`~sim.hand.grasp_env.GraspEnv.set_object_load`), from the readings after
        the step before.
    until : callable, optional
        ``until(t_s, info) -> bool``: the task has its answer after the step at ``t_s``.
    command : callable, optional
        ``command(t_s, info, reference_n) -> N``: what the hand does to the reference the
        paradigm made at ``t_s`` (from the readings after the step before), e.g. an
        involuntary opening (:class:`~scenarios.runners.slip_perturbations.Opening`).
        While it lowers the reference below the grip, the motor may open at full speed
        whatever the paradigm bounds it to (the lower bound becomes -1): the hand opens
        under ``velocity`` too, where a relaxed person stops the motor.
    frames : Frames, optional
        Keep frames for a video (``traces["frames"]`` for RGB frames).
    keep_observations : bool
        The recorder keeps the controller's observations and commands
        (:attr:`TrialRecorder.observations`, :attr:`TrialRecorder.computed`).
    """

    load: Callable[[float, Mapping[str, Any]], float] | None = None
    until: Callable[[float, Mapping[str, Any]], bool] | None = None
    command: Callable[[float, Mapping[str, Any], float], float] | None = None
    frames: Frames | None = None
    keep_observations: bool = False


NO_HOOKS = TrialHooks()
"""A trial the task adds nothing to."""


@dataclass(frozen=True)
class TrialTiming:
    """How long a trial may last and how often its controller acts.

    Attributes
    ----------
    limit_s : float
        The trial's time limit, s.
    control_dt_s : float
        Control period, s (a multiple of the 2 ms physics step); the trial has
        ``round(limit_s / control_dt_s)`` steps at most.
    """

    limit_s: float
    control_dt_s: float


class TrialRecorder:
    """Every trace of a trial, filled step by step (:meth:`traces` returns them).

    Parameters
    ----------
    n_steps : int
        Control steps the trial may last.
    with_load : bool
        Also record the task's load on the object (``object_load_n``).
    keep_observations : bool
        Also keep what the controller acted on and what it computed at each step
        (:attr:`observations`, :attr:`computed`), for a replay through other code.
    """

    #: The per-step traces, in the order :meth:`traces` returns them.
    NAMES = ("reference_n", "grip_force_n", "command", "object_height_m", "slip_speed_m_s",
             "wrist_height_m", "both_sides", "tracked_reference_n")

    def __init__(self, n_steps: int, *, with_load: bool = False,
                 keep_observations: bool = False) -> None:
        n = int(n_steps)
        self.reference, self.grip, self.command = np.zeros(n), np.zeros(n), np.zeros(n)
        self.height, self.slip, self.wrist = np.zeros(n), np.zeros(n), np.zeros(n)
        self.tracked = np.zeros(n)
        self.both = np.zeros(n, dtype=bool)
        self.loads = np.zeros(n) if with_load else None
        self.observations: list[Any] | None = [] if keep_observations else None
        self.computed: list[float] | None = [] if keep_observations else None
        self.frames: list[Any] = []

    def record(self, k: int, reference_n: float, info: Mapping[str, Any], command: float,
               tracked_n: float) -> None:
        """The readings after step ``k``."""
        self.reference[k] = reference_n
        self.grip[k] = info["grip_force_n"]
        self.command[k] = command
        self.height[k], self.slip[k] = info["object_height_m"], info["slip_speed_m_s"]
        self.wrist[k] = info["wrist_height_m"]
        self.both[k] = info["thumb_contact"] and info["finger_contact"]
        self.tracked[k] = tracked_n

    def traces(self, t_s: np.ndarray, n_run: int) -> dict[str, np.ndarray]:
        """The first ``n_run`` steps of every trace, with their times ``t_s``."""
        out = {"t_s": t_s[:n_run], "reference_n": self.reference[:n_run],
               "grip_force_n": self.grip[:n_run], "command": self.command[:n_run],
               "object_height_m": self.height[:n_run], "slip_speed_m_s": self.slip[:n_run],
               "wrist_height_m": self.wrist[:n_run], "both_sides": self.both[:n_run],
               "tracked_reference_n": self.tracked[:n_run]}
        if self.loads is not None:
            out["object_load_n"] = self.loads[:n_run]
        if self.frames and not isinstance(self.frames[0], tuple):
            out["frames"] = np.stack(self.frames)
        return out


class TrialLoop:
    """One grasp of ``obj`` by ``person`` through ``design``'s controller (module notes).

    Parameters
    ----------
    obj : ObjectSpec
        The object on the table.
    design : controllers.design.ControllerDesign
        The designed controller (its runtime controller drives the hand).
    person : Person
        Who drives the trial.
    timing : TrialTiming
        The trial's time limit and control period.
    lift_height_m : float or None
        The lift the task asks for (the referee's secure lift), m; ``None``: held on
        the table.
    seed : int
        Seeds the environment's reset.
    hooks : TrialHooks
        The task's load on the object and its own ending rule, the frames for a video
        and whether the recorder keeps the controller's observations (default: none).
    hand : HandSettings
        The hand's drive and paradigm (its slip response is in ``design``:
        :meth:`~scenarios.runners.trial_loop.HandSettings.controller_spec`).

    Attributes
    ----------
    k : int
        Steps run.
    info : dict
        The environment's ``info`` after the last step.
    ended : str or None
        Why the trial ended (:data:`ENDINGS`); ``None`` while it runs.
    referee : TrialReferee
    recorder : TrialRecorder
    """

    def __init__(self, obj: ObjectSpec, design: Any, person: Person, timing: TrialTiming, *,
                 lift_height_m: float | None, seed: int, hooks: TrialHooks = NO_HOOKS,
                 hand: HandSettings = DEFAULT_HAND) -> None:
        limit_s, control_dt_s = timing.limit_s, timing.control_dt_s
        load, until, frames = hooks.load, hooks.until, hooks.frames
        self.design, self.person, self.seed = design, person, int(seed)
        self.hand = hand
        self.paradigm = make_paradigm(hand.paradigm)
        self._decoded = uses_decoder(self.paradigm)
        if getattr(self.paradigm, "needs_decoder", False) and \
                getattr(person, "decoded", None) is None:
            raise DecoderMissingError(
                f"paradigm {hand.paradigm} needs open and close signals, but the calibration "
                "has no open contractions (no decoder was fitted); expected a calibration "
                "with open contractions (griploop calibrate --open)")
        self.dt = float(control_dt_s)
        self.n_steps = int(round(limit_s / control_dt_s))
        self.t_s = np.arange(self.n_steps) * self.dt
        rgb = frames is not None and frames.kind == "rgb"
        hand_spec, task = hand.env_specs(limit_s)
        self.env = GraspEnv(obj, 0.0, control_dt_s=control_dt_s, wrist="commanded",
                            hand=hand_spec, task=task,
                            render_mode="rgb_array" if rgb else None)
        self.hand_loop = HandLoop(self.env, design.controller)
        self.lift_height_m = lift_height_m
        self.referee = TrialReferee(lift_height_m)
        self.recorder = TrialRecorder(self.n_steps, with_load=load is not None,
                                      keep_observations=hooks.keep_observations)
        self.load, self.until, self.frames = load, until, frames
        self.command = hooks.command
        self._frame_every = (None if frames is None
                             else max(1, int(round(frames.every_s / control_dt_s))))
        self._load_n = 0.0
        self.k = 0
        self.info: dict[str, Any] = {}
        self.ended: str | None = None

    def keep_frames(self, frames: Frames) -> None:
        """Keep frames from now on (a video asked for after the trial was made)."""
        if frames.kind == "rgb" and self.env.render_mode != "rgb_array":
            raise ValueError("keep_frames: RGB frames need a trial made with frames")
        self.frames = frames
        self._frame_every = max(1, int(round(frames.every_s / self.dt)))

    def reset(self) -> dict[str, Any]:
        """Reset the controller and the hand (seeded); a fresh referee and recorder."""
        self.info = self.hand_loop.reset(seed=self.seed)
        self.paradigm.reset()
        self.referee = TrialReferee(self.lift_height_m)
        self.recorder = TrialRecorder(self.n_steps, with_load=self.load is not None,
                                      keep_observations=self.recorder.observations is not None)
        self._load_n = 0.0
        self.k = 0
        self.ended = None
        return self.info

    def step(self, reference_n: float | None = None) -> bool:
        """Run control step ``k``; True when the trial has ended (``ended`` says why).

        Parameters
        ----------
        reference_n : float, optional
            Overrides the person's reference at this step (a live session holding its
            grip through a gap of the stream), N.
        """
        k, info, env, rec = self.k, self.info, self.env, self.recorder
        t = float(self.t_s[k])
        ref, move = self.person.act(k, scene_from_info(t, info),
                                    env.commanded.height_m(env.data.time))
        if self._decoded:
            ref = self.paradigm.step(ref, getattr(self.person, "decoded", None))
        else:
            ref = self.paradigm.step(ref)
        # a paradigm that bounds the motor (velocity) says so; the others leave it alone
        bounds = getattr(self.paradigm, "command_range", None)
        if self.command is not None:
            ref, bounds = self._commanded(t, info, ref, bounds)
        if reference_n is not None:
            ref = reference_n
        if move is not None:
            env.move_wrist(move.height_m, move.duration_s, move.path)
        if self.load is not None:
            new_load = float(self.load(t, info))
            if new_load != self._load_n:
                env.set_object_load(new_load)
                self._load_n = new_load
            rec.loads[k] = self._load_n
        env.set_reference(ref)
        _, command, _ = self.hand_loop.step(ref, bounds=bounds)
        self.info = info = self.hand_loop.info
        rec.record(k, ref, info, command, max(ref, self.design.core.last_reference_n))
        if rec.observations is not None:
            rec.observations.append(self.hand_loop.observation)
            rec.computed.append(float(self.hand_loop.computed))
        if self._frame_every is not None and k % self._frame_every == 0:
            rec.frames.append(env.render() if self.frames.kind == "rgb"
                              else (env.data.qpos.copy(), bool(info["crushed"])))
        self.referee.update(t, info)
        self.k = k + 1
        self.ended = self._ending(t, info)
        return self.ended is not None

    def _commanded(self, t: float, info: Mapping[str, Any], ref: float,
                   bounds: tuple[float, float] | None
                   ) -> tuple[float, tuple[float, float] | None]:
        """The task's ``command`` hook on the paradigm's reference ``ref`` (N) and the motor's
        bounds: opening allowed while the hook holds the reference below the grip."""
        hooked = float(self.command(t, info, ref))
        if bounds is not None and hooked < ref and hooked < info["grip_force_n"]:
            bounds = (FULL_RANGE[0], bounds[1])
        return hooked, bounds

    def _ending(self, t: float, info: Mapping[str, Any]) -> str | None:
        """The ending rule (module notes), after the step at ``t``."""
        if "failure" in info:
            return "diverged"
        referee = self.referee
        if referee.over:
            return referee.ended_by
        if self.person.done:
            return "done"
        if self.until is not None and self.until(t, info):
            return "task"
        return "duration" if self.k >= self.n_steps else None

    def run(self) -> None:
        """Reset, then step until the trial ends; the environment is closed after."""
        try:
            self.reset()
            while not self.step():
                pass
        finally:
            self.env.close()

    @property
    def failure(self) -> str | None:
        """MuJoCo's warning if the physics diverged."""
        return self.info.get("failure")

    def traces(self) -> dict[str, np.ndarray]:
        """The traces of the steps run."""
        return self.recorder.traces(self.t_s, self.k)

    @property
    def controller_s(self) -> float:
        """Wall time in the controller since the reset, s."""
        return self.hand_loop.controller_s

    @property
    def physics_s(self) -> float:
        """Wall time in the physics since the reset, s."""
        return self.hand_loop.physics_s
