"""What became of a trial the user paced: the ground truth the task is judged on.

A user who moves their own arm lifts when they choose, tries again when the object
stays behind and puts it down when done, so the outcome cannot be read off a fixed
schedule. :class:`TrialReferee` watches the hand's physical readings (never the
user's perception) at every control step:

* **first contact**: both sides of the hand first touch the object;
* **secure lift**: the object has risen at least half the lift height above where it
  rested, while the hand still touches it (carried, not knocked);
* **fell**: after a secure lift, the object is out of the hand (no digit touches it and
  it has moved more than the drop distance from where the hand held it);
* **crushed**: the grip exceeded the break force.

The outcome (:data:`scenarios.outcomes.OUTCOMES`) is ``crushed``, else ``dropped`` if it
fell after a secure lift, else ``held`` after a secure lift, else ``not_lifted`` (the
time ran out before a secure lift; tries that left the object behind are attempts, not
drops).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from controllers.bounds import slip_threshold_n
from scenarios.outcomes import outcome_of
from scenarios.runners.episode_metrics import was_lifted
from sim.hand.objects import ObjectSpec

LIFTED_FRACTION = 0.5
"""A secure lift: the object rose at least this fraction of the lift height in the hand."""
SETTLE_S = 0.3
"""The hold's grip is read from this long after the secure lift (the lift's end), s."""


class TrialReferee:
    """The task's ground truth of one trial (module notes).

    Parameters
    ----------
    lift_height_m : float
        The lift the task asks for, m.
    """

    def __init__(self, lift_height_m: float) -> None:
        self.lift_height_m = float(lift_height_m)
        self.rest_height_m: float | None = None
        self.first_contact_s: float | None = None
        self.secure_lift_s: float | None = None
        self.fell_s: float | None = None
        self.crushed = False

    def update(self, t_s: float, info: Mapping[str, Any]) -> None:
        """Account the readings ``info`` after the control step at ``t_s``."""
        height = info["object_height_m"]
        if self.rest_height_m is None:
            self.rest_height_m = height
        touching = info["thumb_contact"] or info["finger_contact"]
        if self.first_contact_s is None and info["thumb_contact"] and info["finger_contact"]:
            self.first_contact_s = t_s
        if (self.secure_lift_s is None and touching
                and height - self.rest_height_m >= LIFTED_FRACTION * self.lift_height_m):
            self.secure_lift_s = t_s
        if self.secure_lift_s is not None and self.fell_s is None and info["object_out_of_hand"]:
            self.fell_s = t_s
        self.crushed = self.crushed or bool(info["crushed"])

    @property
    def over(self) -> bool:
        """The trial has its answer whatever the user does next: crushed, or fallen."""
        return self.crushed or self.fell_s is not None

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


def judge_trial(traces: Mapping[str, np.ndarray], info: Mapping[str, Any],
                referee: TrialReferee | None) -> tuple[bool, bool, bool, str]:
    """``(lifted, dropped, crushed, outcome)`` of one trial.

    A trial the user paced is judged by its referee; on the scripted schedule, by the
    object's height trace (``object_height_m``) and the environment's last ``info``
    (``dropped``, ``crushed``; absent counts as False).
    """
    if referee is not None:
        return (referee.secure_lift_s is not None, referee.fell_s is not None,
                referee.crushed, referee.outcome)
    lifted = was_lifted(traces["object_height_m"])
    dropped, crushed = bool(info.get("dropped", False)), bool(info.get("crushed", False))
    return lifted, dropped, crushed, outcome_of(lifted=lifted, dropped=dropped,
                                                crushed=crushed)
