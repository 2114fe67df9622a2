"""Every parameter of the reacting user, each with its source and its physical range.

Checked at construction (:class:`OperatorParamsError`, one line naming the field) and by
the scenario schema (``user.params``, refused at load with FILE:LINE).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

from sim.errors import GriploopError


class OperatorParamsError(GriploopError, ValueError):
    """An operator parameter is outside its physical range."""


def _param(default: float, lo: float, hi: float, unit: str, *, integer: bool = False,
           open_low: bool = False, added: bool = False) -> Any:
    """A parameter with its range and unit; ``added``: added after scenario seeds were first
    derived (left at its default, it stays out of a scenario's canonical JSON)."""
    return field(default=default, metadata={"range": (lo, hi), "unit": unit,
                                            "integer": integer, "open_low": open_low,
                                            "added": added})


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
    vision_noise_time_s : float
        Correlation time of that error, s: 0.1, vision integrates over about
        100 ms (Bloch's law's critical duration), so the seen position does not
        jitter independently at every control step.
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
        level the first lift needed: 1.0, the force of a lift is programmed
        from the weight of the previous one (Johansson and Westling 1984,
        1988); later lifts move it less (``min_learning_rate``).
    motor_noise_cv : float
        Coefficient of variation of the intent's signal-dependent noise:
        0.045, force SD grows linearly with mean force (Jones, Hamilton and
        Wolpert 2002, J Neurophysiol 88:1533); CV 4.06 % with vision and
        4.47 % without (Baweja et al. 2009, Exp Brain Res 197:35).
    motor_noise_time_s : float
        Correlation time of that noise, s: 0.25, so that it passes the
        muscles' 3 Hz activation dynamics as the slow force fluctuations of
        steady contractions do (chosen).

    The arm, moved by the user (:mod:`sim.user.reacting`, "the trial"):

    touch_delay_s : float
        Delay of what an intact hand feels (feedback ``touch``), s: 0.074, the
        latency of the grip's response to a slip (Johansson and Westling 1987,
        Exp Brain Res 66:141).
    touch_dwell_s : float
        How long an intact hand feels the grasp closed before lifting, s: 0.1,
        the preload phase of precision grip (about 0.1-0.2 s, Johansson and
        Westling 1984).
    dwell_s : float
        How long the hand must be seen closed on the object and still before
        the user lifts, s: 0.3. Prosthesis users keep their eyes on the hand
        until the grasp is complete and only then transport the object, where
        intact hands look ahead (Sobuh et al. 2014, JNER 11:72); the intact
        preload phase before the load rises lasts about 0.1-0.2 s (Johansson
        and Westling 1984). The figure is chosen within that picture.
    still_rad_s : float
        Finger speed below which the digits are seen to have stopped closing,
        rad/s: 0.2, a third of this hand's free closing speed (about 0.6 rad/s);
        the pads' compression under a fluctuating grip moves them more slowly
        than that (chosen).
    liftoff_height_m : float
        Height of the careful first lift, m: 0.01. People lift carefully at
        first and watch whether the object comes along (issue 27; chosen).
    liftoff_s : float
        Duration of that lift-off, s: 0.5 (2 cm/s; chosen).
    lift_s : float
        Duration of the lift and of the set-down, s: 0.6; natural reach and
        transport movements of 20-40 cm take about 0.5-0.8 s, nearly whatever
        their length (Jeannerod 1984, J Mot Behav 16:235).
    release_s : float
        How long relaxing the contraction takes when the object is put down, s:
        0.3; muscle force relaxes 100-200 ms behind the drive (CALIBRATION.md,
        "Physiology"), plus the decision (chosen).

    release_wait_s : float
        How long after relaxing the user waits for the hand to open before they
        give up, s: 3.0 (chosen). A hand whose estimate does not fall below
        the rest threshold stays closed.
    open_level : float
        How hard the user contracts to open a hand that opens on a second signal
        (a two-signal paradigm, :mod:`controllers.paradigms`), as a fraction of their
        largest opening contraction: 0.6, the middle of the calibration's open levels
        (0.3, 0.6, 1.0: :func:`sim.user.intent.open_protocol`). A deliberate, not a
        maximal, contraction (chosen; no published figure for how hard users open).

    What the user knows of their prosthesis (:mod:`sim.user.belief`):

    min_learning_rate : float
        The smallest fraction of a lift's error that moves the user's belief of
        how hard to contract: 0.2. The rate starts at ``anticipation_weight``
        after the first lift and falls as ``1 / (n + 1)`` (averaging noisy
        outcomes; adaptation rates follow the noise, Burge, Ernst and Banks
        2008, J Vis 8(4):20) down to this floor, which keeps the belief
        following a device that changes (chosen).

    intact_margin : float
        Grip over the slip force that an intact hand keeps: 0.25, the middle of
        the 10-40 % of precision grip (CALIBRATION.md, "Practised users";
        Westling and Johansson 1984). A practised user's margin never goes below it.
    novice_margin : float
        The margin of a user who has not practised with this prosthesis: 0.5,
        the aim of every user of griploop 0.4 (1.5 x the slip force), kept so
        that ``practice 0`` is that novice; prosthesis users grip with larger
        margins than intact hands (Brown et al. 2015, JNER). Its excess over
        :attr:`intact_margin` is the novice's uncertainty about the device.
    uncertainty_rate : float
        Weight of the newest lift in the user's estimate of how variable the
        prosthesis is: 0.3, so the last three or four lifts weigh most (chosen).
    margin_per_uncertainty : float
        Safety margin, in log units, per unit of that variability (its RMS in
        log units): 1.0, a margin that covers one standard deviation of the
        errors met. Safety margins scale with the variability a person
        experiences (Hadjiosif and Smith 2015, J Neurosci 35:9106).

    The intact hand's anticipatory grip-load coupling (:mod:`sim.user.grip_load`; only a
    plan that couples grip to load, the ``intact`` reference's, uses these):

    preload_n : float
        The grip the user builds at contact before any load, N: 0.5. The preload phase
        of a lift raises the grip a little before the load starts (Johansson and
        Westling 1984, Exp Brain Res 56:550); the coupled grip is this plus the load's
        share (chosen small against the slip forces of the objects lifted: no figure of
        the preload's size was read for it).
    grip_lead_s : float
        How far ahead of the load the user commands the grip they plan for it, s: 0.2,
        their own delay from command to force, so that grip and load rise together as
        an internal model predicts them (Flanagan and Wing 1997, J Neurosci 17:1519):
        the electromechanical delay (40-140 ms, middle 90 ms) plus the activation's
        group delay (a critically damped second order at about 3 Hz, 2 / (2 pi 3 Hz) =
        106 ms; CALIBRATION.md, "Physiology"). The user starts raising the grip when
        they decide to lift and moves the arm this much later: the loading phase before
        lift-off (Johansson and Westling 1984).
    """

    vision_delay_s: float = _param(0.2, 0.0, 1.0, "s")
    visible_slip_m: float = _param(0.002, 0.0, 0.05, "m")
    vision_noise_m: float = _param(0.0005, 0.0, 0.01, "m")
    vision_noise_time_s: float = _param(0.1, 0.0, 2.0, "s", open_low=True)
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
    touch_delay_s: float = _param(0.074, 0.0, 0.5, "s")
    touch_dwell_s: float = _param(0.1, 0.0, 1.0, "s")
    dwell_s: float = _param(0.3, 0.0, 3.0, "s")
    still_rad_s: float = _param(0.2, 0.0, 2.0, "rad/s", open_low=True)
    liftoff_height_m: float = _param(0.01, 0.002, 0.05, "m")
    liftoff_s: float = _param(0.5, 0.05, 3.0, "s")
    lift_s: float = _param(0.6, 0.1, 3.0, "s")
    release_s: float = _param(0.3, 0.01, 2.0, "s")
    release_wait_s: float = _param(3.0, 0.0, 10.0, "s")
    open_level: float = _param(0.6, 0.05, 1.0, "", added=True)
    min_learning_rate: float = _param(0.2, 0.0, 1.0, "")
    intact_margin: float = _param(0.25, 0.0, 1.0, "")
    novice_margin: float = _param(0.5, 0.0, 3.0, "")
    uncertainty_rate: float = _param(0.3, 0.0, 1.0, "")
    margin_per_uncertainty: float = _param(2.0, 0.0, 5.0, "", open_low=True)
    preload_n: float = _param(0.5, 0.0, 5.0, "N", added=True)
    grip_lead_s: float = _param(0.2, 0.0, 1.0, "s", added=True)

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
        if self.novice_margin < self.intact_margin:
            raise OperatorParamsError(
                f"OperatorParams.novice_margin: expected at least intact_margin "
                f"({self.intact_margin:g}), found {self.novice_margin!r}")

    @classmethod
    def ranges(cls) -> dict[str, dict[str, Any]]:
        """Each field's ``default``, ``range``, ``unit``, ``integer``, ``open_low`` and
        ``added``."""
        return {f.name: {"default": f.default, **f.metadata} for f in fields(cls)}

    def to_dict(self) -> dict[str, float]:
        """JSON-ready parameters."""
        return {f.name: getattr(self, f.name) for f in fields(self)}
