"""One trial of a virtual user: their calibrated prosthesis, the designed controller and the hand.

:func:`run_trial` plans the trial from its :class:`~scenarios.runners.reference.Task`
(:func:`~scenarios.runners.reference.plan_for`), puts the user in it
(:class:`~scenarios.runners.person.VirtualPerson`) and runs the one trial loop
(:class:`~scenarios.runners.trial_loop.TrialLoop`): every user moves their own arm (the
scripted one at a set time, once the grip is established; a reacting one when the grip
looks secure, again after the object stayed behind), and the trial ends by the loop's
one rule (the referee's answer, the user done, the task's rule, the time limit).
Episodes, practice and every benchmark task run their trials here.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from controllers.design import ControllerDesign
from scenarios.runners.calibration import Calibration
from scenarios.runners.dispatch import DivergedError, UnsupportedScenarioError
from scenarios.runners.person import VirtualPerson, hand_for
from scenarios.runners.reference import ReferenceStream, Task, plan_for, reference_from_windows
from scenarios.runners.semg_reference import STEP_MS, WINDOW_MS
from scenarios.runners.trial_loop import (
    DEFAULT_HAND,
    NO_HOOKS,
    HandSettings,
    TrialHooks,
    TrialLoop,
    TrialTiming,
    scene_from_info,
)
from scenarios.runners.trial_outcome import TrialReferee
from sim.hand.objects import ObjectSpec
from sim.user.causal import NotCausalError
from sim.user.operator import Operator, OperatorError, TrialMemory
from sim.user.subjects import VirtualSubject

HAND_FORCE_AT_MVC_N = 30.0
"""The hand force commanded at the user's strongest calibration squeeze, N (module notes of
:mod:`scenarios.runners.episode`)."""

#: The timing fields of a row, s (wall time in each part of the loop).
TIMING_KEYS = ("t_semg_s", "t_features_s", "t_estimator_s", "t_operator_s", "t_controller_s",
               "t_physics_s")


@dataclass(frozen=True)
class TrialSetup:
    """What the trials of one user with one prosthesis share.

    Attributes
    ----------
    subject : VirtualSubject
        The user's body (with any electrode shift, noise or fatigue applied).
    obj : ObjectSpec
        The object.
    calibration : Calibration
        The fitted estimator (or the oracle) and the force mapping's scale.
    design : ControllerDesign
        The designed controller.
    generator : str
        The sEMG generator.
    control_dt_s, hand_force_at_mvc_n : float
        Control period, s, and the hand force at the user's calibration MVC, N.
    window_ms, step_ms : float
        The feature window and its increment, ms (the calibration's).
    hand : HandSettings
        The hand's drive, paradigm and slip response (the design carries the slip
        response already: :meth:`~scenarios.runners.trial_loop.HandSettings.controller_spec`).
    """

    subject: VirtualSubject
    obj: ObjectSpec
    calibration: Calibration
    design: ControllerDesign
    generator: str = "noise"
    control_dt_s: float = 0.01
    hand_force_at_mvc_n: float = HAND_FORCE_AT_MVC_N
    window_ms: float = WINDOW_MS
    step_ms: float = STEP_MS
    hand: HandSettings = DEFAULT_HAND


@dataclass
class Trial:
    """One closed-loop trial: the traces, how it ended, and the reference it ran on.

    Attributes
    ----------
    traces : dict of ndarray
        The recorder's traces plus ``user_intent``.
    failure : str or None
        MuJoCo's warning if the physics diverged.
    info : dict
        The environment's last ``info``.
    stream : ReferenceStream
        The reference and the user's true force at the control rate (for the metrics).
    referee : TrialReferee
        The trial's ground truth (outcome, attempts, lift, release).
    ended : str
        Why it ended (:data:`scenarios.runners.trial_loop.ENDINGS`).
    memory : TrialMemory
        What the user remembers of it (their aim, corrections, what they saw).
    phases : list of (float, str)
        When the user's phases began (empty for a user without phases), s.
    timings : dict
        Wall time in each part of the loop (:data:`TIMING_KEYS`), s.
    decoding : dict
        With a decoder: ``decoder_windows`` (windows decoded) and ``unrequested_opens``
        (windows decoded as open while the user was not opening); empty without one.
    """

    traces: dict[str, np.ndarray]
    failure: str | None
    info: dict[str, Any]
    stream: ReferenceStream
    referee: TrialReferee
    ended: str
    memory: TrialMemory
    phases: list[tuple[float, str]] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    decoding: dict[str, int] = field(default_factory=dict)

    @property
    def attempts(self) -> int:
        """Lifts the user started (the referee's count)."""
        return self.referee.attempts

    def raise_if_diverged(self, what: str = "") -> None:
        """Raise :class:`~scenarios.runners.dispatch.DivergedError` if the physics diverged.

        The message names MuJoCo's warning and the time, after ``what`` (e.g.
        ``"practice lift: "``).
        """
        if self.failure is not None:
            raise DivergedError(f"{what}physics diverged at t = {self.info['time_s']:.3f} s: "
                                f"{self.failure}")


def run_trial(setup: TrialSetup, operator: Operator, task: Task,
              seeds: tuple[np.random.SeedSequence, np.random.SeedSequence,
                           np.random.SeedSequence],
              hooks: TrialHooks = NO_HOOKS) -> Trial:
    """One trial of ``task`` by ``operator`` with ``setup``'s body, prosthesis and hand.

    Parameters
    ----------
    setup : TrialSetup
    operator : Operator
        The user's mind and arm (started here, finished after the trial).
    task : Task
        What the trial asks; its time limit defaults to the user's own.
    seeds : (SeedSequence, SeedSequence, SeedSequence)
        The sEMG session (script timing and noise), the environment and the operator.
    hooks : TrialHooks
        The task's load, its own ending rule, frames.

    Raises
    ------
    UnsupportedScenarioError
        A user who reacts with an sEMG generator that cannot run causally, or a plan the
        user cannot follow (a scripted lift with no time to grasp).
    """
    episode_seq, env_seq, operator_seq = seeds
    limit_s = float(operator.default_trial_s if task.limit_s is None else task.limit_s)
    rng = np.random.default_rng(episode_seq)
    plan, start_s = plan_for(task, limit_s, setup.subject, setup.calibration,
                             setup.hand_force_at_mvc_n, rng)
    try:
        person = VirtualPerson(setup, operator, plan, session_rng=rng,
                               operator_rng=np.random.default_rng(operator_seq))
    except (NotCausalError, OperatorError) as exc:
        raise UnsupportedScenarioError(f"user {operator.name}: {exc}") from None
    loop = TrialLoop(setup.obj, setup.design, person, TrialTiming(limit_s, setup.control_dt_s),
                     lift_height_m=task.lift_height_m, seed=int(env_seq.generate_state(1)[0]),
                     hooks=hooks, hand=hand_for(setup.calibration.name, setup.hand))
    loop.run()
    # the user goes on to the limit seeing the last scene, so the windows and the true
    # force cover the whole trial (its estimation metrics), as a scripted session does
    person.play_out(loop.k, loop.n_steps, scene_from_info(0.0, loop.info))
    person.intent_until(int(round(loop.n_steps * setup.control_dt_s * person.fs_hz)))
    traces = loop.traces()
    traces["user_intent"] = person.intent[
        np.minimum((traces["t_s"] * person.fs_hz).round().astype(int), person.n_samples - 1)]
    timings = {**dict.fromkeys(TIMING_KEYS, 0.0), **person.all_timings(),
               "t_controller_s": loop.controller_s, "t_physics_s": loop.physics_s}
    stream = _stream(person, start_s, loop.t_s, traces["reference_n"], limit_s)
    phases = list(operator.phase_log)
    memory = operator.finish()
    return Trial(traces, loop.failure, loop.info, stream, loop.referee, str(loop.ended),
                 memory, phases, timings, person.reference.decoder_counts(
                     np.zeros(person.n_samples) if person.open_intent is None
                     else person.open_intent))



def _stream(person: VirtualPerson, start_s: float, t_ctrl: np.ndarray,
            reference_n: np.ndarray, limit_s: float) -> ReferenceStream:
    """The :class:`ReferenceStream` a virtual person produced (for the metrics)."""
    window_t = np.asarray(person.reference.window_t_s)
    estimates = np.asarray(person.reference.window_values_n)
    oracle = reference_from_windows(person.window_oracle_n(), window_t, t_ctrl)
    return ReferenceStream(start_s, estimates[window_t <= limit_s], person.hop / person.fs_hz,
                           t_ctrl, reference_n, oracle)
