"""Artificial sensory feedback: what a prosthesis tells its user, and how it is felt.

A feedback mode is a device that codes one of the hand's sensors into a
stimulus on the residual limb, plus the user's perception of that stimulus
(delay ``feedback_delay_s`` and noise, from :class:`~sim.user.operator.OperatorParams`).
Registered modes (:mod:`sim.user.operators`):

``none``
    Vision only.
``force_vibration``
    Grip force coded as the nearest of ``vibration_levels`` vibration
    intensities, which stand for 0, 1/n, 2/n, ... of the hand force at the
    user's MVC (n levels; the top one also for anything above); no vibration
    without contact. A target given as a fraction k/n of the maximum (the
    force-matching targets 20/40/60 % with 5 levels) is the centre of its
    level, as experiments give targets in feedback levels. The user perceives
    the level with a delay and, near a level boundary, confuses neighbours
    (``vibration_noise_levels``).
``slip_vibration``
    A discrete burst of ``slip_burst_s`` each time the hand's slip sensor
    crosses ``slip_speed_m_s`` (DESC-style event feedback: Johansson and Edin's
    discrete event-driven control); the user perceives the burst's onset with
    a delay.
``touch``
    An intact hand's own touch, for the references the user's own force drives
    (``intact``, ``ideal_interface``): contact and slips
    felt ``touch_delay_s`` late (the grip responds to a slip 74 ms after it
    starts, Johansson and Westling 1987). A user who feels contact knows the
    grasp is secure without watching the hand and lifts without a careful
    lift-off (:mod:`sim.user.reacting`).

A mode is a class with ``name``, ``codes_force``, ``start(control_dt_s=,
force_range_n=, rng=)``, ``perceive(scene) -> Felt`` and ``level_of(force_n)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.user.operator import DelayLine, OperatorParams, Scene

CONTACT_N = 0.5
"""Grip force below which a force-feedback device is silent, N."""


@dataclass(frozen=True)
class Felt:
    """What the user feels at one step.

    Attributes
    ----------
    slip : bool
        The onset of a slip burst is felt now.
    level : int or None
        The vibration level felt (``None``: no vibration, or no force coding).
    contact : bool or None
        Both sides of the hand felt touching the object (``None``: a mode that
        does not tell contact).
    """

    slip: bool = False
    level: int | None = None
    contact: bool | None = None


_NOTHING = Felt()


def nearest_level(x: float, levels: int) -> int:
    """The nearest of ``levels`` vibration levels to ``x`` (in level units), 0..levels-1."""
    return int(min(max(math.floor(x + 0.5), 0), levels - 1))


def force_level(force_n: float, force_range_n: float, levels: int) -> int:
    """The vibration level coding a grip force: level ``k`` stands for ``k / levels`` of the
    range (module notes)."""
    return nearest_level(levels * force_n / force_range_n, levels)


class NoFeedback:
    """Vision only: nothing is felt."""

    name = "none"
    codes_force = False

    def __init__(self, params: OperatorParams | None = None) -> None:
        self.params = params or OperatorParams()

    def start(self, *, control_dt_s: float, force_range_n: float,
              rng: np.random.Generator) -> None:
        """Begin a trial (nothing to set up)."""

    def perceive(self, scene: Scene) -> Felt:
        """Nothing."""
        return _NOTHING

    def level_of(self, force_n: float) -> int | None:
        """No force code."""
        return None


class ForceVibration(NoFeedback):
    """Grip force as vibration intensity with a few discriminable levels (module notes)."""

    name = "force_vibration"
    codes_force = True

    def start(self, *, control_dt_s: float, force_range_n: float,
              rng: np.random.Generator) -> None:
        """Begin a trial: the coded range and the perception delay."""
        self._range = float(force_range_n)
        self._rng = rng
        self._line = DelayLine(round(self.params.feedback_delay_s / control_dt_s))

    def level_of(self, force_n: float) -> int:
        """The device's level for a grip force: the nearest of its intensities, 0..levels-1."""
        return force_level(force_n, self._range, self.params.vibration_levels)

    def _nearest(self, x: float) -> int:
        return nearest_level(x, self.params.vibration_levels)

    def perceive(self, scene: Scene) -> Felt:
        """The level felt now: the delayed force's level, with confusion near boundaries."""
        force = self._line.push(scene.grip_force_n)
        if force is None or force < CONTACT_N:
            return _NOTHING
        x = self.params.vibration_levels * force / self._range
        return Felt(level=self._nearest(x + self.params.vibration_noise_levels
                                        * self._rng.standard_normal()))


class SlipVibration(NoFeedback):
    """A discrete vibration burst at each slip event (module notes)."""

    name = "slip_vibration"

    def start(self, *, control_dt_s: float, force_range_n: float,
              rng: np.random.Generator) -> None:
        """Begin a trial: burst timing and the perception delay."""
        self._dt = float(control_dt_s)
        self._line = DelayLine(round(self.params.feedback_delay_s / control_dt_s))
        self._burst_until = -math.inf
        self._slipping = False
        self._was_on = False

    def perceive(self, scene: Scene) -> Felt:
        """Whether a burst's onset is felt now."""
        p = self.params
        fast = scene.slip_speed_m_s > p.slip_sensor_m_s
        if fast and not self._slipping and scene.t_s >= self._burst_until:
            self._burst_until = scene.t_s + p.slip_burst_s
        self._slipping = fast if fast else scene.slip_speed_m_s >= 0.5 * p.slip_sensor_m_s \
            and self._slipping
        on = self._line.push(scene.t_s < self._burst_until)
        onset = bool(on) and not self._was_on
        self._was_on = bool(on)
        return Felt(slip=True) if onset else _NOTHING


class Touch(SlipVibration):
    """An intact hand's touch: contact and slips felt, ``touch_delay_s`` late (module notes)."""

    name = "touch"
    feels_contact = True

    def start(self, *, control_dt_s: float, force_range_n: float,
              rng: np.random.Generator) -> None:
        """Begin a trial: slips as bursts of the slip sensor, felt with touch's delay."""
        super().start(control_dt_s=control_dt_s, force_range_n=force_range_n, rng=rng)
        steps = round(self.params.touch_delay_s / control_dt_s)
        self._line = DelayLine(steps)
        self._contact = DelayLine(steps)

    def perceive(self, scene: Scene) -> Felt:
        """A slip's onset and whether the hand touches the object, as felt now."""
        slip = super().perceive(scene).slip
        contact = self._contact.push(scene.contact)
        return Felt(slip=slip, contact=bool(contact))


class FeedbackDevice:
    """What a feedback mode's stimulator outputs at each control step (no perception).

    The device side of :class:`ForceVibration` and :class:`SlipVibration`, for a lab's
    tactor driver (``griploop live --feedback``, the ``griploop.feedback`` stream):
    ``output`` is an intensity 0..1.

    - ``force_vibration``: the level of the grip force, ``level / (levels - 1)``, with
      :meth:`ForceVibration.level_of`'s code; 0 without contact (below 0.5 N).
    - ``slip_vibration``: 1 while a burst of ``slip_burst_s`` runs (a burst starts when the
      slip sensor crosses ``slip_sensor_m_s``, re-armed when it falls under half of it),
      else 0.
    - ``none``: always 0.

    Parameters
    ----------
    mode : str
        ``none``, ``force_vibration`` or ``slip_vibration``.
    force_range_n : float
        Grip force the top vibration level stands for (the hand force at the user's MVC), N.
    params : OperatorParams, optional
        Levels, burst length and slip threshold.

    Raises
    ------
    ValueError
        An unknown mode (naming the valid ones).
    """

    MODES = ("none", "force_vibration", "slip_vibration")

    def __init__(self, mode: str, *, force_range_n: float,
                 params: OperatorParams | None = None) -> None:
        if mode not in self.MODES:
            raise ValueError(f"feedback: expected one of {', '.join(self.MODES)}, found {mode!r}")
        self.mode = mode
        self.params = params or OperatorParams()
        self._range = float(force_range_n)
        self._burst_until = -math.inf
        self._slipping = False

    def output(self, t_s: float, grip_force_n: float, slip_speed_m_s: float) -> float:
        """The stimulator's intensity (0..1) at time ``t_s`` (s) for the hand's sensors."""
        p = self.params
        if self.mode == "force_vibration":
            if grip_force_n < CONTACT_N:
                return 0.0
            level = force_level(grip_force_n, self._range, p.vibration_levels)
            return level / max(p.vibration_levels - 1, 1)
        if self.mode == "slip_vibration":
            fast = slip_speed_m_s > p.slip_sensor_m_s
            if fast and not self._slipping and t_s >= self._burst_until:
                self._burst_until = t_s + p.slip_burst_s
            self._slipping = fast or (self._slipping and slip_speed_m_s >= 0.5 * p.slip_sensor_m_s)
            return 1.0 if t_s < self._burst_until else 0.0
        return 0.0
