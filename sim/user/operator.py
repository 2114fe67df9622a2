"""The person in the loop: what the user perceives of the hand, and how they change their intent.

A prosthesis user has no slip reflex through the socket: they see the hand and
the object, and feel whatever artificial feedback the prosthesis gives. Every
perception here goes through a *channel* with a delay, a threshold and noise,
and the user's policy reads only the channels, never the simulator:

* **vision** (always): contact of the hand on the object, the object sliding in
  the hand (seen once it has slid at least ``visible_slip_m``), a drop, a
  broken object; delay ``vision_delay_s``;
* **feedback** (optional, :mod:`sim.user.feedback`): ``force_vibration`` (grip
  force coded as one of ``vibration_levels`` vibration intensities) or
  ``slip_vibration`` (a discrete burst at each slip event the hand's sensor
  detects, DESC-style); delay ``feedback_delay_s``.

The user acts on intent (fraction of MVC), through the muscles, sEMG,
estimator and controller that already exist:

* **corrective squeeze**: a perceived slip (seen, or felt as a burst) raises
  the intended grip by ``correction_gain`` along a ``correction_rise_s``
  raised-cosine ramp; corrections are intermittent, at most one per
  ``refractory_s`` (the user waits to see the effect);
* **force tracking with force feedback**: while the perceived vibration level
  differs from the level of the force the user aims at, the intent steps by
  ``force_step`` towards it, one step per ``refractory_s``;
* **anticipatory scaling across trials** (Johansson and Westling): the next
  lift's planned level moves by ``anticipation_weight`` towards the level the
  previous lift needed (after its corrections), higher after a perceived
  drop, lower after a perceived break;
* **signal-dependent motor noise**: the intent carries multiplicative
  Ornstein-Uhlenbeck noise of coefficient of variation ``motor_noise_cv``, so
  force SD grows with mean force.

The runner (:mod:`scenarios.runners.operator_loop`) passes a :class:`Scene` of
plain numbers each control step and gets the next samples of intent back;
nothing here imports the hand. Operator models and feedback modes are
registered by name (:mod:`sim.user.operators`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any, Protocol

import numpy as np

from sim.errors import GriploopError


class OperatorParamsError(GriploopError, ValueError):
    """An operator parameter is outside its physical range."""


def _param(default: float, lo: float, hi: float, unit: str, *, integer: bool = False,
           open_low: bool = False) -> Any:
    return field(default=default, metadata={"range": (lo, hi), "unit": unit,
                                            "integer": integer, "open_low": open_low})


@dataclass(frozen=True)
class OperatorParams:
    """Every parameter of the reacting user, with its source.

    Attributes
    ----------
    vision_delay_s : float
        Delay of what the user sees, s: 0.2, the middle of the visuomotor
        reaction of 150-250 ms (CALIBRATION.md, "The person in the loop";
        a prosthesis user has no slip reflex through the socket).
    visible_slip_m : float
        Slide of the object in the hand that the user sees as a slip, m:
        2 mm (issue 20: "at least 2 mm visible slip").
    vision_noise_m : float
        Standard deviation of the seen slide, m: 0.5 mm, a quarter of the
        visible threshold (chosen; no published figure for a slide seen on a
        prosthesis).
    feedback_delay_s : float
        Delay of the artificial feedback (vibration on the residual limb), s:
        0.15, a voluntary grip change cued by a skin stimulus takes about
        twice the 74 ms of the slip reflex (Johansson and Westling 1987,
        Exp Brain Res 66:141); simple reaction times to vibrotactile cues
        move by 20-300 ms with location and load (Bao et al. 2019, PLoS ONE
        14:e0219737).
    vibration_levels : int
        Discriminable vibration intensities that code grip force over the
        user's range (the nearest of 0, 1/n, 2/n, ... of the hand force at
        their MVC, :mod:`sim.user.feedback`): 5
        ("a few discriminable levels", issue 20; fewer levels are recognized
        more accurately, Sensors 2019, 19:5209).
    vibration_noise_levels : float
        Standard deviation of the perceived intensity, in levels: 0.15, so
        that only forces near a level boundary are confused (chosen).
    slip_sensor_m_s : float
        Slip speed at which the hand's slip sensor emits a burst, m/s:
        0.005, the simulator's slip-event threshold (:mod:`sim.hand.contact`).
    slip_burst_s : float
        Duration of one slip burst, s: 0.1; a new burst needs a new slip
        event (DESC-style discrete feedback; chosen).
    correction_gain : float
        Relative rise of the intended grip in one corrective squeeze: 0.3.
        After a slip the grip/load ratio rises to a new level held for the
        rest of the hold (Johansson and Westling 1987); the size is chosen,
        equal to the controller's slip-reflex gain, as no single published
        figure applies to a myoelectric user.
    correction_rise_s : float
        Duration of a squeeze's raised-cosine rise, s: 0.15, about three
        muscle time constants of 50-66 ms (Todorov 2005; CALIBRATION.md).
    refractory_s : float
        Shortest interval between two corrections, s: 0.5, intermittent
        human corrections about twice a second (Craik 1947, Br J Psychol
        38:56; the psychological refractory period).
    force_step : float
        Relative change of the intended grip per correction from force
        feedback: 0.1 (chosen; a discrete code says only "more" or "less").
    anticipation_weight : float
        Fraction by which the next lift's planned level moves towards the
        level the previous lift needed: 1.0, the force of a lift is
        programmed from the weight of the previous one (Johansson and
        Westling 1984, 1988).
    motor_noise_cv : float
        Coefficient of variation of the intent's signal-dependent noise:
        0.045, force SD grows linearly with mean force (Jones, Hamilton and
        Wolpert 2002, J Neurophysiol 88:1533); CV 4.06 % with vision and
        4.47 % without (Baweja et al. 2009, Exp Brain Res 197:35).
    motor_noise_time_s : float
        Correlation time of that noise, s: 0.25, so that it passes the
        muscles' 3 Hz activation dynamics as the slow force fluctuations of
        steady contractions do (chosen).
    """

    vision_delay_s: float = _param(0.2, 0.0, 1.0, "s")
    visible_slip_m: float = _param(0.002, 0.0, 0.05, "m")
    vision_noise_m: float = _param(0.0005, 0.0, 0.01, "m")
    feedback_delay_s: float = _param(0.15, 0.0, 1.0, "s")
    vibration_levels: int = _param(5, 2, 16, "levels", integer=True)
    vibration_noise_levels: float = _param(0.15, 0.0, 2.0, "levels")
    slip_sensor_m_s: float = _param(0.005, 0.0, 0.1, "m/s", open_low=True)
    slip_burst_s: float = _param(0.1, 0.01, 1.0, "s")
    correction_gain: float = _param(0.3, 0.0, 2.0, "")
    correction_rise_s: float = _param(0.15, 0.0, 1.0, "s")
    refractory_s: float = _param(0.5, 0.0, 5.0, "s")
    force_step: float = _param(0.1, 0.0, 1.0, "")
    anticipation_weight: float = _param(1.0, 0.0, 1.0, "")
    motor_noise_cv: float = _param(0.045, 0.0, 1.0, "")
    motor_noise_time_s: float = _param(0.25, 0.0, 10.0, "s", open_low=True)

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            lo, hi = f.metadata["range"]
            unit = f" {f.metadata['unit']}" if f.metadata["unit"] else ""
            kind = "an integer" if f.metadata["integer"] else "a number"
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            ok = ok and math.isfinite(value) and (lo < value if f.metadata["open_low"]
                                                  else lo <= value) and value <= hi
            if f.metadata["integer"]:
                ok = ok and float(value).is_integer()
            if not ok:
                low = f"above {lo:g}" if f.metadata["open_low"] else f"{lo:g}"
                raise OperatorParamsError(
                    f"OperatorParams.{f.name}: expected {kind} in {low}..{hi:g}{unit}, "
                    f"found {value!r}")
        object.__setattr__(self, "vibration_levels", int(self.vibration_levels))

    @classmethod
    def ranges(cls) -> dict[str, dict[str, Any]]:
        """Each field's ``default``, ``range``, ``unit``, ``integer`` and ``open_low``."""
        return {f.name: {"default": f.default, **f.metadata} for f in fields(cls)}

    def to_dict(self) -> dict[str, float]:
        """JSON-ready parameters."""
        return {f.name: getattr(self, f.name) for f in fields(self)}


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
        the object slides down in the hand).
    object_height_m : float
        Height of the object's centre above the table, m.
    dropped, crushed : bool
        The object fell out of the hand, or broke.
    grip_force_n : float
        The hand's grip-force sensor, N (what a force-feedback device codes).
    slip_speed_m_s : float
        The hand's slip sensor, m/s (what a slip-feedback device detects).
    """

    t_s: float
    contact: bool
    object_in_hand_m: float
    object_height_m: float
    dropped: bool
    crushed: bool
    grip_force_n: float
    slip_speed_m_s: float


@dataclass(frozen=True)
class Plan:
    """What the user sets out to do in one trial.

    Attributes
    ----------
    intent : ndarray, shape (n_samples,)
        The scripted intent of the trial (rest, ramp, hold; fraction of MVC)
        at ``fs_hz``; its shape is kept, its hold level is the user's.
    fs_hz : float
        Sampling rate of the intent, Hz.
    hold_level : float
        The hold level of ``intent`` (fraction of MVC).
    goal_n : float
        Hand grip force the user aims at, N.
    force_range_n : float
        Hand force the user commands at their MVC, N (the range a force
        feedback device codes).
    """

    intent: np.ndarray
    fs_hz: float
    hold_level: float
    goal_n: float
    force_range_n: float


@dataclass
class TrialMemory:
    """What the user remembers of a trial (for the next one's plan).

    Attributes
    ----------
    planned_level, final_level : float
        The hold level planned and the one reached after corrections.
    slip_seen, drop_seen, break_seen : bool
        What the user perceived during the trial.
    corrections : int
        Corrections made.
    """

    planned_level: float
    final_level: float
    slip_seen: bool = False
    drop_seen: bool = False
    break_seen: bool = False
    corrections: int = 0


class Operator(Protocol):
    """A user model driving the intent (registered in :mod:`sim.user.operators`).

    ``start`` begins a trial; ``perceive`` is called once per control step, in
    order, with the scene after the previous step (the user decides there);
    ``intent`` returns the next ``n_samples`` of intent (fraction of MVC) at the
    plan's rate, for sample times at or before the last perceived step's time
    (the runner asks when a feature window needs them, so a decision never
    changes samples before it); ``finish`` ends the trial (what the user
    learnt feeds the next ``start``). ``corrections`` counts the corrections
    of the current trial and ``correction_times`` lists when they were decided
    (episode time, s).
    """

    name: str
    corrections: int
    correction_times: list[float]

    def start(self, plan: Plan, *, control_dt_s: float, rng: np.random.Generator) -> None: ...

    def perceive(self, scene: Scene) -> None: ...

    def intent(self, n_samples: int) -> np.ndarray: ...

    def finish(self) -> TrialMemory: ...


class OperatorError(GriploopError, ValueError):
    """An operator used out of order or with a feedback it cannot take."""


class ScriptedOperator:
    """The user who follows the script: the plan's intent, whatever the hand does.

    Takes no feedback (``feedback`` must be ``None`` or ``"none"``); makes no
    corrections; the paper's calibration session is this user.
    """

    name = "scripted"

    def __init__(self, params: OperatorParams | None = None, feedback: Any = None) -> None:
        if feedback is not None and getattr(feedback, "name", feedback) != "none":
            name = getattr(feedback, "name", feedback)
            raise OperatorError(
                f"feedback applies to the reacting user only: the scripted user takes "
                f"feedback none (found {name})")
        self.params = params or OperatorParams()
        self.corrections = 0
        self.correction_times: list[float] = []
        self._plan: Plan | None = None
        self._n = 0

    def start(self, plan: Plan, *, control_dt_s: float, rng: np.random.Generator) -> None:
        """Begin a trial (the scripted user ignores ``rng``)."""
        self._plan, self._n, self.corrections = plan, 0, 0

    def perceive(self, scene: Scene) -> None:
        """Nothing: the scripted user does not look."""

    def intent(self, n_samples: int) -> np.ndarray:
        """The plan's next ``n_samples`` of intent."""
        plan = _started(self._plan)
        i0 = self._n
        self._n += n_samples
        return _take(plan.intent, i0, n_samples)

    def finish(self) -> TrialMemory:
        """The trial as planned (nothing learnt)."""
        plan = _started(self._plan)
        return TrialMemory(plan.hold_level, plan.hold_level)


def _started(plan: Plan | None) -> Plan:
    if plan is None:
        raise OperatorError("operator used before start(plan)")
    return plan


def _take(x: np.ndarray, i0: int, n: int) -> np.ndarray:
    """``x[i0:i0+n]``, padded with its last value past the end."""
    out = x[i0:i0 + n]
    if out.size < n:
        out = np.concatenate([out, np.full(n - out.size, x[-1] if x.size else 0.0)])
    return out


def _ramp(dt_s: Any, lo: float, hi: float, rise_s: float) -> Any:
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


class ReactingOperator:
    """The user who sees, feels and reacts (module notes).

    Parameters
    ----------
    params : OperatorParams, optional
        Every setting (default :class:`OperatorParams`).
    feedback : FeedbackMode or str or None
        The artificial feedback (:mod:`sim.user.feedback`; a registered name
        or an instance); ``None`` or ``"none"``: vision only.
    """

    name = "reacting"

    def __init__(self, params: OperatorParams | None = None, feedback: Any = None) -> None:
        from sim.user.operators import make_feedback

        self.params = params or OperatorParams()
        self.feedback = make_feedback("none" if feedback is None else feedback, self.params)
        self.corrections = 0
        self.correction_times: list[float] = []
        self._memory: TrialMemory | None = None
        self._plan: Plan | None = None

    # ------------------------------------------------------------------ trial
    def start(self, plan: Plan, *, control_dt_s: float, rng: np.random.Generator) -> None:
        """Begin a trial: plan the hold level from the previous trial, draw the motor noise.

        ``rng`` is split into independent streams (motor noise, vision,
        feedback) so that the same seed gives the same motor noise whatever
        the feedback mode: paired comparisons.
        """
        from sim.user.muscles import slow_fluctuation  # scipy.signal: imported when used

        p = self.params
        noise_rng, vision_rng, feedback_rng = rng.spawn(3)
        self._plan = plan
        self._dt = float(control_dt_s)
        self._sample_dt = 1.0 / plan.fs_hz
        self._shape = plan.intent / plan.hold_level if plan.hold_level > 0 else plan.intent * 0.0
        self._planned = self._anticipate(plan.hold_level)
        self._level_to = self._planned
        self._changes: list[tuple[float, float, float]] = []  # (t_s, from, to)
        self._noise = 1.0 + slow_fluctuation(plan.intent.size, plan.fs_hz,
                                             np.array([p.motor_noise_cv]),
                                             p.motor_noise_time_s, noise_rng)[:, 0]
        n_steps = int(math.ceil(plan.intent.size / (plan.fs_hz * self._dt))) + 2
        self._vision_noise = (p.vision_noise_m * vision_rng.standard_normal(n_steps)).tolist()
        self._vision = DelayLine(round(p.vision_delay_s / self._dt))
        self._step = 0
        self.feedback.start(control_dt_s=self._dt, force_range_n=plan.force_range_n,
                            rng=feedback_rng)
        self._feels = getattr(self.feedback, "name", "") != "none"  # vision only: no call
        self._goal_level = self.feedback.level_of(plan.goal_n) if self.feedback.codes_force \
            else None
        self._anchor: float | None = None  # where the object sat in the hand, as seen
        self._next_ok_s = -math.inf
        self._released_s = math.inf
        self._n = 0
        self.corrections = 0
        self.correction_times: list[float] = []
        self._trial = TrialMemory(self._planned, self._planned)

    def _anticipate(self, scripted_level: float) -> float:
        """The planned hold level: the script's, moved towards what the last trial needed."""
        m = self._memory
        if m is None:
            return scripted_level
        needed = m.final_level
        g = self.params.correction_gain
        if m.drop_seen:  # it needed more than it got: one squeeze more
            needed = m.final_level * (1.0 + g)
        elif m.break_seen:  # it needed less: one squeeze less
            needed = m.final_level / (1.0 + g)
        w = self.params.anticipation_weight
        return float(np.clip(m.planned_level + w * (needed - m.planned_level), 0.0, 1.0))

    def level(self, t_s: float) -> float:
        """The intended hold level at ``t_s`` (fraction of MVC), ramps included."""
        out = self._planned
        for t_c, lo, hi in self._changes:
            if t_s >= t_c:
                out = _ramp(t_s - t_c, lo, hi, self.params.correction_rise_s)
        return out

    def _change(self, t_s: float, factor: float) -> None:
        self.correction_times.append(t_s)
        now = self.level(t_s)
        self._level_to = float(np.clip(self._level_to * factor, 0.0, 1.0))
        self._changes.append((t_s, now, self._level_to))
        self._next_ok_s = t_s + self.params.refractory_s
        self.corrections += 1

    # ------------------------------------------------------------------ step
    def perceive(self, scene: Scene) -> None:
        """Perceive ``scene`` through the channels and decide (module notes)."""
        if self._plan is None:
            _started(None)
        p = self.params
        t = scene.t_s
        seen = self._vision.push(scene)
        felt = self.feedback.perceive(scene) if self._feels else None
        slide = 0.0
        if seen is not None:  # vision: the delayed scene, with noise on the seen slide
            noise = self._vision_noise
            slide = seen.object_in_hand_m + noise[self._step % len(noise)]
            if seen.contact and self._anchor is None:
                self._anchor = slide
            if (seen.dropped or seen.crushed) and self._released_s == math.inf:
                self._trial.drop_seen |= bool(seen.dropped)
                self._trial.break_seen |= bool(seen.crushed)
                self._released_s = t  # the user lets go
        self._step += 1
        if self._released_s == math.inf and t >= self._next_ok_s:
            slip_seen = (seen is not None and self._anchor is not None
                         and self._anchor - slide >= p.visible_slip_m)
            if slip_seen or (felt is not None and felt.slip):
                self._trial.slip_seen = True
                self._change(t, 1.0 + p.correction_gain)
                self._anchor = slide if seen is not None and seen.contact else None
            elif felt is not None and felt.level is not None and self._goal_level is not None \
                    and felt.level != self._goal_level:
                up = felt.level < self._goal_level
                self._change(t, (1.0 + p.force_step) if up else (1.0 - p.force_step))

    def intent(self, n_samples: int) -> np.ndarray:
        """The next ``n_samples`` of intent: the plan's shape x the level x motor noise, 0..1."""
        plan = _started(self._plan)
        i0 = self._n
        self._n += n_samples
        idx = np.minimum(np.arange(i0, i0 + n_samples), self._shape.size - 1)
        t = np.arange(i0, i0 + n_samples) / plan.fs_hz
        level = np.full(n_samples, self._planned)
        rise = self.params.correction_rise_s
        for t_c, lo, hi in self._changes:  # later changes override earlier ones
            after = t >= t_c
            if after.any():
                level[after] = _ramp(t[after] - t_c, lo, hi, rise)
        out = np.clip(self._shape[idx] * level * self._noise[idx], 0.0, 1.0)
        out[t >= self._released_s] = 0.0
        return out

    def finish(self) -> TrialMemory:
        """End the trial; what the user learnt plans the next one."""
        _started(self._plan)
        self._trial.final_level = self._level_to
        self._trial.corrections = self.corrections
        self._memory = self._trial
        return self._trial
