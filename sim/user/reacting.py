"""The user who sees, feels and reacts, moves their own arm, and tries again.

**Perception.** Every perception goes through a channel with a delay, a threshold
and noise (:class:`~sim.user.operator_params.OperatorParams` has the figures and
their sources):

* **vision** (always): contact of the hand on the object, whether the digits
  still move, the object sliding in the hand (seen once it has slid at least
  ``visible_slip_m`` from where it sat), the object out of the hand, a broken
  object; delay ``vision_delay_s``, noise on the seen slide;
* **without vision** (a plan with ``sees`` false: the test without vision of Raveh et
  al. 2018, Arch Phys Med Rehabil 99:2263): none of the above. What stays is the
  incidental cue of the digits moving: a powered hand's motor is heard running or silent
  (users rely on it, Markovic et al. 2018, J NeuroEng Rehabil 15:28; Wilke et al. 2019,
  J NeuroEng Rehabil 16:120), an intact hand's own digits are felt moving; same delay as
  vision (chosen: auditory reactions are, if anything, faster). The user then judges the
  grasp secure once the hand was heard closing (moving after their contraction began)
  and fell silent, lifts without a careful lift-off (there is nothing to watch),
  squeezes harder while the hand is not heard moving at all, perceives a drop or a break
  only through feedback, and takes the hand as open once it was heard opening and fell
  silent. With force feedback the grip's vibration also tells contact: the grasp is
  secure only once it is felt (silent without it: squeeze harder), and its stop during
  the lift is a drop;
* **feedback** (optional, :mod:`sim.user.feedback`): ``force_vibration`` or
  ``slip_vibration``; delay ``feedback_delay_s``.

**The trial** (when the plan has a lift; the user's arm is theirs, the runner hands
its moves to the hand's commanded wrist)::

    grasp    contract to the planned level; the hand closes. Once the hand is seen
             closed on the object and still for ``dwell_s`` and the contraction is
             complete, lift off. (A user who feels contact through touch, as with
             the intact hand or the ideal interface, lifts once it has been felt for
             ``touch_dwell_s``, without a careful lift-off.)
    liftoff  raise the wrist ``liftoff_height_m`` in ``liftoff_s`` and watch one
             vision delay more. The object seen sliding in the hand (it stays on
             the table) or out of it: put it down, squeeze harder (one
             correction, ``correction_gain``), back to grasp: a new attempt.
             Otherwise lift on.
    lift     raise to the plan's height in ``lift_s`` and hold for ``hold_s``,
             correcting seen slips as below. The object seen out of the hand
             before it was seen carried up (half the lift): it stayed behind,
             put down and try again; after that: dropped, let go.
    setdown  lower the wrist back in ``lift_s``,
    release  relax the contraction in ``release_s``; the trial is done once the
             hand is seen open (it let go), or after ``release_wait_s`` more
             if it does not open (an estimate that does not fall to zero at
             rest keeps the hand closed: :attr:`released` is then false).
             A hand that opens on a second signal (``plan.open_to_release``) is
             opened: the user also contracts to open, to ``open_level`` of their
             largest opening, in ``release_s``; done once it is seen open.
             A user who lets go (a drop or a break seen) opens it likewise.

A plan without a lift (holding a force on the table) stays in one hold phase. There a
slip felt before the hand has held the object for ``touch_dwell_s`` is the object
pushed by the closing digits, not a slip of a held object: it is not answered.

**Corrections** (while lifting and holding, and on the table):

* a perceived slip (seen, or felt as a burst) raises the intended grip by
  ``correction_gain`` along a ``correction_rise_s`` raised-cosine ramp, at most
  once per ``refractory_s`` (the user waits to see the effect);
* with force feedback, while the felt vibration level differs from the level
  of the force the user aims at, the intent steps by ``force_step`` towards it,
  one step per ``refractory_s``;
* a hand that stays open while the user contracts (the estimate does not close
  it) is squeezed for harder, once per ``refractory_s``.

**Planning and practice.** The planned contraction comes from the user's
:class:`~sim.user.belief.ProsthesisBelief` (how hard to contract for this
prosthesis, and the safety margin its variability calls for); every finished
trial updates it, so a user who practised plans differently from a novice.
**Motor noise**: the intent carries multiplicative Ornstein-Uhlenbeck noise of
coefficient of variation ``motor_noise_cv`` (force SD grows with mean force).

**Grip coupled to load** (a plan with ``couples_load``: the intact hand). The planned level
is the grip while holding still (:meth:`~sim.user.belief.ProsthesisBelief.aim_n`); the
intent scales it by the grip planned for the load the user expects now over that grip
(:mod:`sim.user.grip_load`): the pre-load only before the lift, the load of the arm's
moves while the object is in the hand. Deciding to lift, such a user raises the grip at
once and starts the arm ``grip_lead_s`` later (the loading phase), without a careful
lift-off whether they feel the grasp or see it.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from sim.user.belief import ProsthesisBelief
from sim.user.grip_load import LoadPlan, anticipated_grip_n
from sim.user.operator import (
    PACED_TRIAL_S,
    DelayLine,
    OperatorParams,
    Plan,
    Scene,
    TrialMemory,
    WristMove,
    ramp,
    started,
)

CARRIED_FRACTION = 0.5
"""The object is seen carried once it rose this fraction of the lift in the hand."""
#: Trial phases of a plan with a lift, in order (``hold`` for a plan without one).
PHASES = ("grasp", "liftoff", "lift", "setdown", "release", "done")


class ReactingOperator:
    """The user who sees, feels, reacts, moves their own arm and tries again (module notes).

    Parameters
    ----------
    params : OperatorParams, optional
        Every setting (default :class:`~sim.user.operator_params.OperatorParams`).
    feedback : FeedbackMode or str or None
        The artificial feedback (:mod:`sim.user.feedback`; a registered name
        or an instance); ``None`` or ``"none"``: vision only.
    belief : ProsthesisBelief, optional
        What the user knows of the prosthesis (default: a novice's).

    Attributes
    ----------
    belief : ProsthesisBelief
        Updated by every :meth:`finish`.
    phase : str
        The trial's phase (:data:`PHASES`, or ``hold``).
    attempts : int
        Lifts started in the current trial.
    done : bool
        The trial is over for the user (put down and released, or let go).
    released : bool
        The hand was seen open when the user finished putting the object down.
    phase_log : list of (float, str)
        When each phase began (episode time, s), for the traces.
    """

    name = "reacting"
    reacts = True
    default_trial_s = PACED_TRIAL_S

    def __init__(self, params: OperatorParams | None = None, feedback: Any = None,
                 belief: ProsthesisBelief | None = None) -> None:
        from sim.user.operators import make_feedback

        self.params = params or OperatorParams()
        self.feedback = make_feedback("none" if feedback is None else feedback, self.params)
        self.belief = belief or ProsthesisBelief.novice(self.params)
        self.corrections = 0
        self.correction_times: list[float] = []
        self.attempts = 0
        self.done = False
        self.released = False
        self.phase = "grasp"
        self.phase_log: list[tuple[float, str]] = []
        self._plan: Plan | None = None

    # ------------------------------------------------------------------ trial
    def start(self, plan: Plan, *, control_dt_s: float, rng: np.random.Generator) -> None:
        """Begin a trial: plan the level from the belief, draw the motor noise.

        ``rng`` is split into independent streams (motor noise, vision,
        feedback) so that the same seed gives the same motor noise whatever
        the feedback mode: paired comparisons.
        """
        from sim.user.muscles import slow_fluctuation  # scipy.signal: imported when used

        p = self.params
        noise_rng, vision_rng, feedback_rng = rng.spawn(3)
        self._plan = plan
        self._dt = float(control_dt_s)
        self._shape = plan.intent / plan.hold_level if plan.hold_level > 0 else plan.intent * 0.0
        self._planned = self.belief.level(plan, p)
        self._level_to = self._planned
        self._changes: list[tuple[float, float, float, float]] = []  # (t_s, from, to, rise_s)
        self._noise = 1.0 + slow_fluctuation(plan.intent.size, plan.fs_hz,
                                             np.array([p.motor_noise_cv]),
                                             p.motor_noise_time_s, noise_rng)[:, 0]
        n_steps = int(math.ceil(plan.intent.size / (plan.fs_hz * self._dt))) + 2
        self._vision_noise = slow_fluctuation(n_steps, 1.0 / self._dt,
                                              np.array([p.vision_noise_m]),
                                              p.vision_noise_time_s, vision_rng)[:, 0].tolist()
        self._vision = DelayLine(round(p.vision_delay_s / self._dt))
        self._step = 0
        self.feedback.start(control_dt_s=self._dt, force_range_n=plan.force_range_n,
                            rng=feedback_rng)
        self._feels = getattr(self.feedback, "name", "") != "none"  # vision only: no call
        self._goal_level = (self.feedback.level_of(self.belief.aim_n(plan, p))
                            if self.feedback.codes_force else None)
        self._load: LoadPlan | None = None  # the load a coupling user expects (none yet)
        self._lift_at_s: float | None = None  # a coupling user's arm lift, due then
        self._anchor: float | None = None  # where the object sat in the hand, as seen
        self._next_ok_s = -math.inf
        self._released_s = math.inf  # let go (a drop or a break seen)
        self._opens: list[tuple[float, float, float, float]] = []  # open intent's ramps
        full = np.flatnonzero(self._shape >= 0.99)
        self._ready_s = float(full[0] / plan.fs_hz) if full.size else 0.0
        onset = np.flatnonzero(self._shape > 0.0)  # the contraction begins (to close)
        self._onset_s = float(onset[0] / plan.fs_hz) if onset.size else 0.0
        self._still_since: float | None = None
        self._contact_since: float | None = None  # on the table: contact perceived since
        self._seen_sum, self._seen_n = 0.0, 0
        self._phase_end_s = math.inf
        self._lift_end_s = math.inf
        self._move: WristMove | None = None
        self._rest_height_m: float | None = None
        self._carried = False  # seen carried up in the hand: out of it now is a drop
        self._heard: float | None = None  # without vision: the digits' speed, heard (rad/s)
        self._heard_moving = False  # the digits were heard moving in this phase
        self._vibrated = False  # a grip's vibration felt in this lift
        self._n = 0
        self.attempts = 0
        self.done = False
        self.released = False
        self.phase_log = []
        self._enter(0.0, "grasp" if plan.lift_height_m is not None else "hold")
        self.corrections = 0
        self.correction_times = []
        self._trial = TrialMemory(self._planned, self._planned,
                                  aim_n=self.belief.aim_n(plan, p))

    def level(self, t_s: float) -> float:
        """The intended hold level at ``t_s`` (fraction of MVC), ramps included."""
        out = self._planned
        for t_c, lo, hi, rise in self._changes:
            if t_s >= t_c:
                out = ramp(t_s - t_c, lo, hi, rise)
        return out

    def _change(self, t_s: float, factor: float) -> None:
        """A correction: the intended level times ``factor`` from ``t_s`` on."""
        self.correction_times.append(t_s)
        now = self.level(t_s)
        self._level_to = float(np.clip(self._level_to * factor, 0.0, 1.0))
        rise = self.params.correction_rise_s
        self._changes.append((t_s, now, self._level_to, rise))
        self._ready_s = max(self._ready_s, t_s + rise)
        self._next_ok_s = t_s + self.params.refractory_s
        self.corrections += 1

    def _enter(self, t_s: float, phase: str) -> None:
        self.phase = phase
        self._heard_moving = False
        self.phase_log.append((float(t_s), phase))

    def _arm(self, height_m: float, duration_s: float) -> None:
        self._move = WristMove(float(height_m), float(duration_s))

    def wrist_move(self) -> WristMove | None:
        """The arm move decided at the last :meth:`perceive` (each move is returned once)."""
        move, self._move = self._move, None
        return move

    # ------------------------------------------------------------------ step
    def perceive(self, scene: Scene) -> None:
        """Perceive ``scene`` through the channels and decide (module notes)."""
        p = self.params
        t = scene.t_s
        seen, slide = self._look(scene)
        felt = self.feedback.perceive(scene) if self._feels else None
        self._step += 1
        if self.done:
            return
        if seen is not None and seen.crushed:
            self._trial.break_seen = True
            self._let_go(t)
            return
        phase = self.phase
        if phase == "grasp":
            self._grasp(t, seen, slide, felt)
        elif phase == "liftoff":
            if seen is not None and (seen.dropped or self._slid(slide)):
                self._retry(t)
            elif t >= self._phase_end_s:
                self._lift(t)
        elif phase == "lift":
            if self._lift_at_s is not None and t >= self._lift_at_s - 1e-9:
                self._arm(float(started(self._plan).lift_height_m or 0.0), self._move_s())
                self._lift_at_s = None
            if not started(self._plan).sees and self._vibration_lost(felt):
                self._trial.drop_seen = True  # the grip's vibration stopped: gone
                self._let_go(t)
                return
            if seen is not None and seen.dropped:
                if not self._carried:  # it stayed behind or slid out low: try again
                    self._retry(t)
                else:
                    self._trial.drop_seen = True
                    self._let_go(t)
                return
            self._correct(t, seen, slide, felt)
            if t >= self._phase_end_s and started(self._plan).place:
                self._arm(0.0, self._move_s())
                self._phase_end_s = t + self._move_s()
                self._enter(t, "setdown")
        elif phase == "setdown":
            if t >= self._phase_end_s:  # on the table: relax (and open, on a second signal)
                now = self.level(t)
                self._changes.append((t, now, 0.0, p.release_s))
                self._open(t)
                self._phase_end_s = t + p.release_s
                self._enter(t, "release")
        elif phase == "release":  # done once the hand is seen (felt) open, or the user gives up
            if felt is not None and felt.contact is not None:
                opened = not felt.contact
            elif not started(self._plan).sees:  # heard opening, then silent
                opened = self._heard_moving and self._silent()
            else:
                opened = seen is not None and not seen.touching
            if t >= self._phase_end_s and (opened or t >= self._phase_end_s + p.release_wait_s):
                self.released = opened
                self.done = True
                self._enter(t, "done")
        else:  # "hold": a force held on the table
            if seen is not None and seen.contact and self._anchor is None:
                self._anchor = slide
            holding = self._holding(t, seen, felt)  # tracked every step
            if felt is not None and felt.slip and not holding:
                felt = replace(felt, slip=False)  # the object pushed as the hand closes on it
            self._correct(t, seen, slide, felt)

    def _look(self, scene: Scene) -> tuple[Scene | None, float | None]:
        """What the eyes give at this step: the scene one vision delay ago and the object's
        seen place in the hand (with the vision noise); ``(None, None)`` before the first
        delay has passed, and without vision, where only the digits are heard (module
        notes)."""
        plan = started(self._plan)
        seen = self._vision.push(scene)
        if seen is None:
            return None, None
        if not plan.sees:
            self._heard = seen.finger_speed_rad_s
            # movement heard before the user contracts (the hand set open) is not theirs
            self._heard_moving |= (self._heard >= self.params.still_rad_s
                                   and scene.t_s >= self._onset_s)
            return None, None
        noise = self._vision_noise
        slide = seen.object_in_hand_m + noise[self._step % len(noise)]
        if self._rest_height_m is None:
            self._rest_height_m = seen.object_height_m
        if (plan.lift_height_m is not None and seen.touching and seen.object_height_m
                - self._rest_height_m >= CARRIED_FRACTION * plan.lift_height_m):
            self._carried = True
        return seen, slide

    def _holding(self, t: float, seen: Scene | None, felt: Any) -> bool:
        """The hand has held the object for ``touch_dwell_s`` (its grip formed), as perceived.

        Contact is felt (touch) or seen; a slip felt before the grip formed is the
        object pushed by the closing digits, which no one answers with a squeeze.
        """
        touching = (bool(felt.contact) if felt is not None and felt.contact is not None
                    else seen is not None and seen.contact)
        if not touching:
            self._contact_since = None
        elif self._contact_since is None:
            self._contact_since = t
        return self._contact_since is not None and t - self._contact_since >= \
            self.params.touch_dwell_s

    def _grasp(self, t: float, seen: Scene | None, slide: float | None, felt: Any) -> None:
        """Closing on the object: lift once it looks (or feels) secure (module notes)."""
        p = self.params
        still = seen is not None and seen.finger_speed_rad_s < p.still_rad_s
        touch = felt is not None and felt.contact is not None
        sees = started(self._plan).sees
        gripped = not self.feedback.codes_force or (felt is not None and felt.level is not None)
        if touch:  # an intact hand feels the grasp closed: no need to watch, no careful lift
            secure, dwell = bool(felt.contact), p.touch_dwell_s
        elif not sees:  # heard closing, then silent (and a grip felt, with force feedback)
            secure, dwell = self._heard_moving and self._silent() and gripped, p.dwell_s
        else:
            secure, dwell = seen is not None and seen.contact and still, p.dwell_s
        if secure:
            if self._still_since is None:
                self._still_since = t
                self._seen_sum, self._seen_n = 0.0, 0
            if seen is not None and seen.contact and slide is not None:
                # where the object sits in the hand: the mean of what was seen while still
                self._seen_sum += slide
                self._seen_n += 1
                self._anchor = self._seen_sum / self._seen_n
        else:
            self._still_since = None
        if self._still_since is not None and t - self._still_since >= dwell and t >= self._ready_s:
            self.attempts += 1
            self._trial.attempts = self.attempts
            if touch or not sees or started(self._plan).couples_load:
                self._lift(t)  # no careful lift-off: felt, nothing to watch, or planned
            else:
                self._arm(p.liftoff_height_m, p.liftoff_s)
                self._phase_end_s = t + p.liftoff_s + p.vision_delay_s
                self._enter(t, "liftoff")
            return
        stays_open = (seen is not None and still and not seen.touching if sees
                      else self._silent() and not (self._heard_moving and gripped))
        if stays_open and t >= self._ready_s + p.dwell_s and t >= self._next_ok_s:
            self._change(t, 1.0 + p.correction_gain)  # the hand does not close: harder
            return
        self._feedback_step(t, felt)

    def _vibration_lost(self, felt: Any) -> bool:
        """Without vision, with force feedback: the grip's vibration, felt earlier in this
        lift, has stopped (the object is out of the hand)."""
        if not self.feedback.codes_force or felt is None:
            return False
        if felt.level is not None:
            self._vibrated = True
            return False
        return self._vibrated

    def _silent(self) -> bool:
        """Without vision: the digits are heard still (the motor is silent)."""
        return self._heard is not None and self._heard < self.params.still_rad_s

    def _move_s(self) -> float:
        """Duration of the lift and of the set-down: the task's, or the user's own."""
        plan = started(self._plan)
        return self.params.lift_s if plan.move_s is None else plan.move_s

    def _lift(self, t: float) -> None:
        """Lift to the plan's height, then hold it there for the plan's hold (a user who
        couples grip to load raises the grip now and the arm ``grip_lead_s`` later)."""
        plan = started(self._plan)
        arm_s = t
        if plan.couples_load:
            arm_s = t + self.params.grip_lead_s
            self._load = LoadPlan(arm_s, float(plan.lift_height_m or 0.0), self._move_s(),
                                  plan.hold_s, plan.place)
            self._lift_at_s = arm_s
        else:
            self._arm(float(plan.lift_height_m or 0.0), self._move_s())
        self._lift_end_s = arm_s + self._move_s()
        self._phase_end_s = self._lift_end_s + plan.hold_s
        self._enter(t, "lift")

    def _slid(self, slide: float | None) -> bool:
        return (slide is not None and self._anchor is not None
                and self._anchor - slide >= self.params.visible_slip_m)

    def _retry(self, t: float) -> None:
        """Put the object down, squeeze harder, and try again."""
        p = self.params
        self._trial.slip_seen = True
        self._arm(0.0, p.lift_s)
        self._load, self._lift_at_s = None, None  # put down: no load expected
        self._change(t, 1.0 + p.correction_gain)
        self._ready_s = max(self._ready_s, t + p.lift_s)
        self._still_since = None
        self._anchor = None
        self._enter(t, "grasp")

    def _correct(self, t: float, seen: Scene | None, slide: float | None, felt: Any) -> None:
        """Squeeze after a perceived slip; follow the force feedback (module notes)."""
        p = self.params
        if t < self._next_ok_s:
            return
        if self._slid(slide) or (felt is not None and felt.slip):
            self._trial.slip_seen = True
            self._change(t, 1.0 + p.correction_gain)
            self._anchor = slide if seen is not None and seen.contact else None
            return
        self._feedback_step(t, felt)

    def _feedback_step(self, t: float, felt: Any) -> None:
        if (t >= self._next_ok_s and felt is not None and felt.level is not None
                and self._goal_level is not None and felt.level != self._goal_level):
            up = felt.level < self._goal_level
            self._change(t, (1.0 + self.params.force_step) if up
                         else (1.0 - self.params.force_step))

    def _let_go(self, t: float) -> None:
        """A drop or a break seen: the user lets go (and opens, on a second signal); the
        trial is over."""
        self._released_s = t
        self._open(t)
        self.done = True
        self._enter(t, "done")

    def _open(self, t: float) -> None:
        """Contract to open from ``t`` on, when the hand opens on a second signal."""
        if started(self._plan).open_to_release:
            self._opens.append((t, 0.0, self.params.open_level, self.params.release_s))

    def open_intent(self, n_samples: int) -> np.ndarray:
        """The open intent of the same ``n_samples`` the last :meth:`intent` call gave, 0..1.

        Zero unless the hand opens on a second signal (``plan.open_to_release``): then
        the opening contraction the user makes to let go (module notes), with the same
        motor noise as the close intent. Call it right after :meth:`intent`.
        """
        plan = started(self._plan)
        i1 = self._n
        i0 = i1 - n_samples
        out = np.zeros(n_samples)
        if not self._opens:
            return out
        t = np.arange(i0, i1) / plan.fs_hz
        idx = np.minimum(np.arange(i0, i1), self._noise.size - 1)
        for t_c, lo, hi, rise in self._opens:
            after = t >= t_c
            if after.any():
                out[after] = ramp(t[after] - t_c, lo, hi, rise)
        return np.clip(out * self._noise[idx], 0.0, 1.0)

    def intent(self, n_samples: int) -> np.ndarray:
        """The next ``n_samples`` of intent: the plan's shape x the level x motor noise, 0..1."""
        plan = started(self._plan)
        i0 = self._n
        self._n = i0 + n_samples
        idx = np.minimum(np.arange(i0, i0 + n_samples), self._shape.size - 1)
        t = np.arange(i0, i0 + n_samples) / plan.fs_hz
        level = np.full(n_samples, self._planned)
        for t_c, lo, hi, rise in self._changes:  # later changes override earlier ones
            after = t >= t_c
            if after.any():
                level[after] = ramp(t[after] - t_c, lo, hi, rise)
        if plan.couples_load:
            level = level * self._load_ratio(t)
        out = np.clip(self._shape[idx] * level * self._noise[idx], 0.0, 1.0)
        out[t >= self._released_s] = 0.0
        return out

    def _load_ratio(self, t_s: np.ndarray) -> np.ndarray:
        """A coupling user's planned grip at ``t_s`` over their grip while holding still:
        the grip for the load expected ``grip_lead_s`` ahead (module notes)."""
        plan, p = started(self._plan), self.params
        hold = self.belief.aim_n(plan, p)
        if plan.need_n is None or hold <= 0:
            return np.ones(t_s.size)
        margin = self.belief.margin(p)
        load = self._load
        return np.array([anticipated_grip_n(plan.need_n, margin, p.preload_n,
                                            0.0 if load is None
                                            else load.load_factor(t + p.grip_lead_s),
                                            plan.break_n) / hold for t in t_s.tolist()])

    def finish(self) -> TrialMemory:
        """End the trial; what the user learnt updates their belief and plans the next one."""
        started(self._plan)
        self._trial.final_level = self._level_to
        self._trial.corrections = self.corrections
        self._trial.attempts = self.attempts
        self.belief = self.belief.learn(self._trial, self.params)
        return self._trial
