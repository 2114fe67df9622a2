"""What became of a trial: the ground truth every trial is judged on, simulated, replayed or live.

Every user moves their own arm: the scripted one at a set time, a reacting one when the
grip looks secure, a person with their forearm. They try again when the object stays
behind and put it down when done, so the outcome cannot be read off a fixed schedule.
:class:`TrialReferee` watches the hand's physical readings (never the user's
perception) at every control step of every trial (:mod:`scenarios.runners.trial_loop`):

* **attempts**: the wrist starts up from the table (its set-point rises above
  :data:`ATTEMPT_RISE_M` after it was within :data:`TABLE_M` of the table): a lift tried;
* **first contact**: both sides of the hand first touch the object;
* **secure lift**: the object has risen at least half the lift height above where it
  rested, while the hand still touches it (carried, not knocked);
* **fell**: after a secure lift, the object is out of the hand (no digit touches it and
  it has moved more than the drop distance from where the hand held it);
* **crushed**: the grip exceeded the break force;
* **released**: at the last step judged, the hand no longer grips the object (at most one
  side touches it: it let go).

The outcome (:data:`scenarios.outcomes.OUTCOMES`) is ``crushed``, else ``dropped`` if it
fell after a secure lift, else ``held`` after a secure lift, else ``not_lifted`` (the
time ran out before a secure lift; tries that left the object behind are attempts, not
drops). The trial is :attr:`~TrialReferee.over` once crushed or fallen: nothing the user
does next changes the outcome.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.bounds import slip_threshold_n
from scenarios.outcomes import outcome_of
from sim.hand.objects import ObjectSpec

LIFTED_FRACTION = 0.5
"""A secure lift: the object rose at least this fraction of the lift height in the hand."""
ATTEMPT_RISE_M = 5e-4
"""The wrist's set-point this far above the table: a lift has started, m."""
TABLE_M = 2.5e-4
"""The wrist's set-point within this of the table: back down, the next rise is a new
attempt, m (a measured arm at rest sits at the table exactly; its set-down approaches it)."""
SETTLE_S = 0.3
"""The hold's grip is read from this long after the secure lift (the lift's end), s."""


class TrialReferee:
    """The task's ground truth of one trial (module notes).

    Parameters
    ----------
    lift_height_m : float or None
        The lift the task asks for, m; ``None``: the object is held on the table
        (no lift can be secure: the outcome is ``not_lifted`` unless crushed).

    Attributes
    ----------
    attempts : int
        Lifts started (the wrist rose from the table).
    released : bool
        The hand did not grip the object (both sides touching) at the last step judged.
    """

    def __init__(self, lift_height_m: float | None) -> None:
        self.lift_height_m = None if lift_height_m is None else float(lift_height_m)
        self._secure_rise_m = (math.inf if lift_height_m is None
                               else LIFTED_FRACTION * float(lift_height_m))
        self.rest_height_m: float | None = None
        self.first_contact_s: float | None = None
        self.secure_lift_s: float | None = None
        self.fell_s: float | None = None
        self.crushed = False
        self.attempts = 0
        self.released = False
        self._on_table = True

    def update(self, t_s: float, info: Mapping[str, Any]) -> None:
        """Account the readings ``info`` after the control step at ``t_s``."""
        height = info["object_height_m"]
        if self.rest_height_m is None:
            self.rest_height_m = height
        wrist = info["wrist_height_m"]
        if self._on_table and wrist > ATTEMPT_RISE_M:
            self.attempts += 1
            self._on_table = False
        elif wrist <= TABLE_M:
            self._on_table = True
        touching = info["thumb_contact"] or info["finger_contact"]
        self.released = not (info["thumb_contact"] and info["finger_contact"])
        if self.first_contact_s is None and info["thumb_contact"] and info["finger_contact"]:
            self.first_contact_s = t_s
        if (self.secure_lift_s is None and touching
                and height - self.rest_height_m >= self._secure_rise_m):
            self.secure_lift_s = t_s
        if self.secure_lift_s is not None and self.fell_s is None and info["object_out_of_hand"]:
            self.fell_s = t_s
        self.crushed = self.crushed or bool(info["crushed"])

    @property
    def over(self) -> bool:
        """The trial has its answer whatever the user does next: crushed, or fallen."""
        return self.crushed or self.fell_s is not None

    @property
    def ended_by(self) -> str | None:
        """Why the referee ended the trial: ``crushed``, ``dropped`` (None while it goes on)."""
        return "crushed" if self.crushed else "dropped" if self.fell_s is not None else None

    @property
    def outcome(self) -> str:
        """``held``, ``not_lifted``, ``dropped`` or ``crushed`` (module notes)."""
        return outcome_of(lifted=self.secure_lift_s is not None, dropped=self.fell_s is not None,
                          crushed=self.crushed)

    @property
    def time_to_lift_s(self) -> float | None:
        """From the first contact to the secure lift, s (None when never lifted)."""
        if self.secure_lift_s is None or self.first_contact_s is None:
            return None
        return self.secure_lift_s - self.first_contact_s


def hold_window(t_s: np.ndarray, wrist_height_m: np.ndarray, secure_lift_s: float | None,
                fell_s: float | None = None, *, down_m: float = 1e-9) -> np.ndarray:
    """Control steps of the in-air hold: from the secure lift (plus :data:`SETTLE_S`) until
    the wrist starts down again, the object fell, or the trial ended (a boolean mask).

    The wrist starts down when it is more than ``down_m`` below its highest point since
    the secure lift (a measured arm's wrist trembles by a millimetre: give it a tolerance).
    """
    mask = np.zeros(t_s.size, dtype=bool)
    if secure_lift_s is None:
        return mask
    start = secure_lift_s + SETTLE_S
    after = np.flatnonzero(t_s >= secure_lift_s)
    end = np.inf if fell_s is None else fell_s
    if after.size > 1:
        height = wrist_height_m[after]
        down = after[height < np.maximum.accumulate(height) - down_m]
        if down.size:
            end = min(end, float(t_s[down[0]]))
    mask[(t_s >= start) & (t_s < end)] = True
    return mask


def safety_margin_pct(grip_n: np.ndarray, hold: np.ndarray, obj: ObjectSpec) -> float | None:
    """Held grip over the slip force, minus 1, in percent: the mean grip of the hold (as the
    held force) over ``m g / (2 mu)`` (None without a hold)."""
    if not hold.any():
        return None
    return float(100.0 * (np.mean(grip_n[hold]) / slip_threshold_n(obj.mass_kg, obj.friction)
                          - 1.0))


def relative_safety_margin_pct(grip_n: np.ndarray, hold: np.ndarray,
                               obj: ObjectSpec) -> float | None:
    """The held grip's excess over the slip force as a share of the grip, in percent:
    ``100 (G - G_slip) / G``, ``G`` the mean grip of the hold and ``G_slip = m g / (2 mu)``
    (None without a hold).

    The safety margin of Westling and Johansson (1984, Exp Brain Res 53:277) is the grip
    above the slip force, ``G - G_slip`` (in newtons, or as the grip/load ratio above the
    slip ratio); expressed relative to the grip it is the "proportion of safety margin in
    the static grip force" (Hiramatsu et al. 2015, PLoS ONE 10:e0138506).
    :func:`safety_margin_pct` gives the same excess relative to the slip force,
    ``(G - G_slip) / G_slip``; :func:`margin_over_grip_pct` converts one to the other.
    """
    margin = safety_margin_pct(grip_n, hold, obj)
    return None if margin is None else margin_over_grip_pct(margin)


def margin_over_grip_pct(margin_pct: float) -> float:
    """griploop's margin (over the slip force, %) as a share of the grip, %:
    ``m / (1 + m)`` with ``m = margin_pct / 100`` (``(G - G_slip) / G`` from
    ``(G - G_slip) / G_slip``)."""
    m = margin_pct / 100.0
    return 100.0 * m / (1.0 + m)


@dataclass(frozen=True)
class Verdict:
    """How one trial is judged, the same for every trial (module notes).

    Attributes
    ----------
    outcome : str
        ``held``, ``not_lifted``, ``dropped`` or ``crushed``.
    lifted, dropped, crushed : bool
        A secure lift; a fall after it; a break.
    attempts : int
        Lifts started.
    time_to_lift_s : float or None
        From the first contact of both sides to the secure lift, s.
    released : bool
        The hand let go by the trial's end.
    lift_start_s : float
        When the wrist first rose, s (the trial's end when it never did).
    hold : ndarray of bool
        The in-air hold's steps (:func:`hold_window`).
    safety_margin_pct : float or None
        The held grip over the slip force, minus 1, % (:func:`safety_margin_pct`; a held
        object only).
    """

    outcome: str
    lifted: bool
    dropped: bool
    crushed: bool
    attempts: int
    time_to_lift_s: float | None
    released: bool
    lift_start_s: float
    hold: np.ndarray
    safety_margin_pct: float | None

    def fields(self) -> dict[str, Any]:
        """The verdict's scalar fields, as a row or a report has them."""
        return {"outcome": self.outcome, "lifted": self.lifted, "dropped": self.dropped,
                "crushed": self.crushed, "attempts": self.attempts,
                "time_to_lift_s": self.time_to_lift_s, "released": self.released,
                "safety_margin_pct": self.safety_margin_pct}


def judge(traces: Mapping[str, np.ndarray], referee: TrialReferee, obj: ObjectSpec, *,
          control_dt_s: float, wrist_tremor_m: float = 0.0) -> Verdict:
    """The verdict of a trial from its traces and its referee.

    Parameters
    ----------
    traces : mapping of ndarray
        ``t_s``, ``wrist_height_m`` and ``grip_force_n`` of the steps run.
    referee : TrialReferee
        The trial's referee, after its last step.
    obj : ObjectSpec
        The object (its slip force, for the safety margin).
    control_dt_s : float
        Control period, s.
    wrist_tremor_m : float
        How much the person's wrist moves when held still (the hold ends when it comes
        down by more), m.
    """
    t, wrist = traces["t_s"], traces["wrist_height_m"]
    hold = hold_window(t, wrist, referee.secure_lift_s, referee.fell_s,
                       down_m=max(wrist_tremor_m, 1e-9))
    rising = np.flatnonzero(wrist > 0.0)
    end_s = float(t[-1]) + control_dt_s if t.size else 0.0
    outcome = referee.outcome
    return Verdict(outcome=outcome, lifted=referee.secure_lift_s is not None,
                   dropped=referee.fell_s is not None, crushed=referee.crushed,
                   attempts=int(referee.attempts), time_to_lift_s=referee.time_to_lift_s,
                   released=bool(referee.released),
                   lift_start_s=float(t[rising[0]]) if rising.size else end_s, hold=hold,
                   safety_margin_pct=safety_margin_pct(traces["grip_force_n"], hold, obj)
                   if outcome == "held" else None)
