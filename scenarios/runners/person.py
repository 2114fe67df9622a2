"""A virtual subject in a trial: perception, intent, arm, sEMG and the hand's reference, causally.

A user who reacts decides at every control step from what the hand did before, so
their sEMG is produced as the trial runs. :class:`VirtualPerson` is the
:class:`~scenarios.runners.trial_loop.Person` of a simulated trial; at every control
step::

    hand (scene after the last step) --Scene: plain numbers--> operator.perceive
        -> intent samples of the windows that have ended (sim.user.causal.CausalSession,
           noise drawn up front) -> sEMG -> SemgReference (features, estimate, gate, map)
        -> hand reference (held between windows); operator.wrist_move -> the arm

The operator sees only the :class:`~sim.user.operator.Scene` (through its channels'
delays, thresholds and noise); ``sim.user`` never imports the hand. A user whose intent
does not depend on what they perceive (``operator.reacts`` false: the scripted user) has
their whole session recorded before the trial instead
(:meth:`sim.user.subjects.VirtualSubject.record`, any sEMG generator): the same samples a
causal session gives (``tests/sim/test_causal.py``), read as the trial's clock reaches
them.

The oracle's reference is the user's true grip at each window's end. The references driven
by the user's own force (:data:`~scenarios.schema.names.OWN_FORCE`, no sEMG path) follow
the user's true grip at every control step: ``ideal_interface`` on the prosthesis's hand,
``intact`` on the intact hand (:func:`hand_for`: the digits pre-shaped and at human speed,
:mod:`sim.hand.human`; its user plans the grip with the load they expect,
:mod:`sim.user.grip_load`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from estimation.features import PAPER_CHANNELS
from scenarios.runners.semg_reference import SemgReference
from scenarios.runners.trial_loop import HandSettings
from scenarios.schema.names import INTACT, OWN_FORCE
from sim.user.causal import CausalSession
from sim.user.operator import Operator, Plan, Scene, WristMove
from sim.user.subjects import VirtualSubject


def hand_for(reference: str, hand: HandSettings) -> HandSettings:
    """The hand a trial of ``reference`` (an estimator, the oracle, ``intact`` or
    ``ideal_interface``) runs on: the intact hand's digits for ``intact``
    (:attr:`~scenarios.runners.trial_loop.HandSettings.human`, backdrivable), else ``hand``."""
    if reference != INTACT:
        return hand
    return replace(hand, drive="backdrivable", human=True)


class RecordedSession:
    """A virtual subject's whole session recorded up front, read as a causal session is.

    For a user whose intent is the plan's (:attr:`~sim.user.operator.Operator.reacts`
    false): :meth:`advance` ignores the intent it is given (the same as the plan's) and
    returns the recorded samples.
    """

    def __init__(self, subject: VirtualSubject, plan: Plan, *, generator: str,
                 rng: np.random.Generator) -> None:
        from sim.user.intent import IntentProfile

        profile = IntentProfile(plan.intent, plan.fs_hz, (), (plan.hold_level,), "script")
        self.recording = subject.record(profile, generator=generator, fs_hz=plan.fs_hz, rng=rng)
        self.n_done = 0

    def advance(self, intent: np.ndarray) -> np.ndarray:
        """The next ``intent.size`` samples of sEMG (int8)."""
        n0 = self.n_done
        self.n_done = n0 + intent.size
        return self.recording.emg[n0:self.n_done]

    def read_forces(self) -> tuple[np.ndarray, np.ndarray]:
        """The user's true grip force and FSR reading of every sample so far, N."""
        rec = self.recording
        return rec.intent_force_n[:self.n_done], rec.force_n[:self.n_done]


class VirtualPerson:
    """A virtual subject and their operator producing the hand reference step by step.

    Parameters
    ----------
    setup : scenarios.runners.trial.TrialSetup
        The user's body (``subject``: muscles, armband, FSR), their fitted estimator or
        the oracle (``calibration``), the sEMG ``generator`` (a causal one for a user who
        reacts), the control period ``control_dt_s``, s, the hand reference at the
        user's calibration MVC ``hand_force_at_mvc_n``, N, and the feature window
        ``window_ms`` and its increment ``step_ms``, ms (the calibration's).
    operator : Operator
        The user's mind and arm (:mod:`sim.user.operators`), started here with ``plan``.
    plan : Plan
        The trial's scripted intent, goal and task.
    session_rng : numpy.random.Generator
        The sEMG session's noise (drawn up front, as ``VirtualSubject.record`` draws it).
    operator_rng : numpy.random.Generator
        The operator's motor and perception noise.

    Raises
    ------
    sim.user.causal.NotCausalError
        A user who reacts with a generator that cannot run causally.
    sim.user.operator.OperatorError
        The plan does not suit the operator (a scripted lift with no time to grasp).
    """

    wrist_tremor_m = 0.0

    def __init__(self, setup: Any, operator: Operator, plan: Plan, *,
                 session_rng: np.random.Generator, operator_rng: np.random.Generator) -> None:
        # setup: a TrialSetup (scenarios.runners.trial imports this module)
        subject, calibration, generator = setup.subject, setup.calibration, setup.generator
        control_dt_s = setup.control_dt_s
        self.fs_hz = float(plan.fs_hz)
        n = int(plan.intent.size)
        self.session = (CausalSession(subject, n, generator=generator, fs_hz=self.fs_hz,
                                      rng=session_rng) if operator.reacts
                        else RecordedSession(subject, plan, generator=generator,
                                             rng=session_rng))
        self.operator = operator
        operator.start(plan, control_dt_s=control_dt_s, rng=operator_rng)
        self.dt = float(control_dt_s)
        self.cal = calibration
        self.reference = SemgReference(
            calibration, fs_hz=self.fs_hz, channel_index=[c - 1 for c in PAPER_CHANNELS],
            window_ms=setup.window_ms, step_ms=setup.step_ms,
            hand_force_at_mvc_n=setup.hand_force_at_mvc_n, forces=self.forces)
        self.hop = self.reference.hop
        self.n_samples = n
        self.intent = np.zeros(n)
        # the open intent of a user who opens the hand on a second signal (else None)
        self.open_intent = np.zeros(n) if plan.open_to_release and operator.reacts else None
        self._n_intent = 0
        self._own_force = calibration.name in OWN_FORCE  # no sEMG path: the true force
        self.to_hand, self.ceiling = self.reference.to_hand, self.reference.ceiling
        self._next_end = self.reference.window.window - 1  # last sample of the next window
        self._reference = 0.0
        self.timings = dict.fromkeys(("t_semg_s", "t_operator_s"), 0.0)

    @property
    def done(self) -> bool:
        """The operator has finished the task."""
        return bool(self.operator.done)

    @property
    def decoded(self) -> Any:
        """The latest window's open and close signals
        (:class:`controllers.paradigms.Decoded`; ``None`` without a decoder)."""
        return self.reference.decoded

    def act(self, k: int, scene: Scene, setpoint_m: float) -> tuple[float, WristMove | None]:
        """The hand reference for control step ``k`` (time ``k * dt``), N, and the arm's move.

        The operator perceives ``scene`` (the hand after step ``k - 1``) and decides;
        every feature window that has ended by ``k * dt`` is then recorded (the intent
        of its samples asked of the operator, all decided by now) and estimated.
        """
        t = k * self.dt
        t0 = time.perf_counter()
        self.operator.perceive(scene)
        self.timings["t_operator_s"] += time.perf_counter() - t0
        # every window whose last sample is no later than t (the batch's rule)
        while self._next_end < self.n_samples and self._next_end / self.fs_hz <= t + 1e-9:
            self._record_to(self._next_end + 1)
            self._next_end += self.hop
        if self._own_force:  # the hand follows the user's own force as it is now
            n = min(int(t * self.fs_hz + 1e-9) + 1, self.n_samples)
            self._record_to(n)
            grip_n, _ = self.forces()
            self._reference = float(np.clip(grip_n[n - 1] * self.to_hand, 0.0, self.ceiling))
        else:
            self._reference = self.reference.reference_n
        return self._reference, self.operator.wrist_move()

    def play_out(self, k_end: int, n_steps: int, scene: Scene) -> None:
        """After a trial that ended at step ``k_end``: the user goes on to ``n_steps``, seeing
        ``scene`` (the last), so the windows cover the whole trial for its metrics."""
        for j in range(k_end, n_steps):
            self.act(j, replace(scene, t_s=j * self.dt), 0.0)

    def intent_until(self, n: int) -> None:
        """Ask the operator for the intent of every sample before ``n`` (decided by now)."""
        n = min(n, self.n_samples)
        if n > self._n_intent:
            t0 = time.perf_counter()
            self.intent[self._n_intent:n] = self.operator.intent(n - self._n_intent)
            if self.open_intent is not None:
                self.open_intent[self._n_intent:n] = self.operator.open_intent(n - self._n_intent)
            self._n_intent = n
            self.timings["t_operator_s"] += time.perf_counter() - t0

    def _record_to(self, n: int) -> None:
        """Record the sEMG of every sample before ``n`` (its intent decided by now) and
        window it."""
        self.intent_until(n)
        t0 = time.perf_counter()
        done = self.session.n_done
        chunk = None
        if n > done:
            opening = None if self.open_intent is None else self.open_intent[done:n]
            chunk = (self.session.advance(self.intent[done:n]) if opening is None
                     or not opening.any() else
                     self.session.advance(self.intent[done:n], open_intent=opening))
        self.timings["t_semg_s"] += time.perf_counter() - t0
        if chunk is not None:
            self.reference.push(chunk)

    def forces(self) -> tuple[np.ndarray, np.ndarray]:
        """The user's true grip force and FSR reading of every sample so far, N."""
        t0 = time.perf_counter()
        out = self.session.read_forces()
        self.timings["t_semg_s"] += time.perf_counter() - t0
        return out

    def window_oracle_n(self) -> np.ndarray:
        """The hand force the user truly produced at each window so far (mapped, clipped), N."""
        grip_n, _ = self.forces()
        oracle = grip_n[np.asarray(self.reference.window_end, dtype=int)] * self.to_hand
        return np.clip(oracle, 0.0, self.ceiling)

    def all_timings(self) -> Mapping[str, float]:
        """Wall time in the sEMG, the operator, the features and the estimator, s."""
        return {**self.timings, **self.reference.timings}
