"""What makes a held object slip in ``slip_recovery``: a rising load, or an involuntary opening.

Both perturbations have one shape (:class:`HeldPerturbation`): each waits until the
object is in the hand at the top of the lift, acts from a start time on, and watches the
hand's ground truth for the slip onset (the hand's slip speed above
:data:`SLIP_ONSET_M_S` with a digit on the object, or the object dropped). The trial
is *recovered* when the object is still in the hand :data:`RECOVERY_WINDOW_S` after
the onset. They read the hand's ground truth because they are the task, not the user:
the user perceives only through their own channels (vision, feedback).

``rising_load`` (griploop's own protocol; the default)
    :data:`LOAD_DELAY_S` after the top of the lift a load hung on the object rises at
    ``protocol.load_rate_n_s`` until the object slips, then stays (:class:`RisingLoad`).
``opening`` (after Aboseria et al. 2018, IEEE TNSRE)
    "Discrete vibro-tactile feedback prevents object slippage in hand prostheses more
    intuitively than other modalities". The published protocol: an *involuntary opening*
    of a myoelectric hand while the person holds an object, and the person's recovery of
    a stable grasp; the paper compares vision alone, continuous grip-force feedback and
    a discrete slip vibration, which recovered "close to 100 %" of the slips "basically
    requiring no learning" (:class:`Opening`). At an unannounced time the hand's grip
    command drops by ``protocol.opening`` times the command then, and stays dropped: the
    hand tracks the person's own command minus that drop (floored at 0), so it closes
    again only when the person squeezes harder. The time is drawn uniformly over
    ``protocol.opening_window_s`` from :data:`LOAD_DELAY_S` after the top of the lift,
    from the trial's own seeded stream (:func:`perturbation_seed`), so nothing the
    person sees announces it. An opening that has not made the object slip
    :data:`RECOVERY_WINDOW_S` later counts as ``no_slip`` and ends the trial.

**How griploop's opening differs from the paper's.** What griploop holds of the paper is
its abstract (shared/CALIBRATION.md; the full text was not read for this): it gives no
size of the opening, no timing of its onset and no criterion of a recovery in numbers.
So these are griploop's choices, made before any run and not fitted to the outcome:

* ``opening = 0.5`` (half the command lost): the grip left is half the grip held, so a
  grip held at up to twice the slip force slips (a margin of up to 100 %: intact
  margins are 10-40 %, Westling & Johansson 1984, and prosthesis users hold larger
  ones, Brown et al. 2015, JNER), while the digits stay on the object, so the slip is a
  slide a squeeze can stop rather than a release; the paper's near-complete recoveries
  need a perturbation that can be recovered. ``opening = 1`` (the whole command lost)
  is allowed;
* ``opening_window_s = 2`` s: several reaction times (a seen slip is answered after a
  vision delay of 0.2 s and a 0.15 s rise, OperatorParams) and four of the user's 0.5 s
  refractory intervals, so a squeeze cannot be timed to the onset;
* recovered: still in the hand :data:`RECOVERY_WINDOW_S` after the slip onset (the
  rising load's rule); the hand is griploop's simulated one (its drive and paradigm as
  the scenario says), not the paper's robotic hand, and the user always sees (the
  paper's "vision" condition is griploop's feedback ``none``).

**The opening on the hand** goes through the trial loop's ``command`` hook
(:class:`~scenarios.runners.trial_loop.TrialHooks`): while the dropped reference is
below the grip the motor may open at full speed whatever the paradigm bounds it to, so
under ``velocity`` (whose relaxed person stops the motor) the hand really opens, and a
``self_locking`` drive then holds it at the dropped grip.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from scenarios.runners.trial_loop import TrialHooks

RECOVERY_WINDOW_S = 2.0
"""Slip recovery: the object must still be held this long after the slip started, s."""
LOAD_DELAY_S = 0.5
"""Slip recovery: the perturbation starts no sooner than this after the lift ends, s."""
SLIP_ONSET_M_S = 0.005
"""Slip recovery: slip speed at which the object has started to slip (a slip event), m/s."""
PERTURBATIONS = ("rising_load", "opening")
"""The perturbations ``protocol.perturbation`` names (module notes)."""


class HeldPerturbation:
    """What the two perturbations share: the start once the object is held up, the slip
    onset after it, and the trial's own ending (module notes).

    Parameters
    ----------
    lift_height_m : float
        The lift's height, m: the wrist at it with a digit on the object is the top.
    delay_s : float
        The perturbation starts at the first step this long after the top with the
        object in the hand, s.
    no_slip_s : float or None
        The trial ends this long after the start if the object has not slipped, s
        (``None``: it runs to its limit).

    Attributes
    ----------
    start_s : float or None
        When the perturbation started (``None``: the object was never held up).
    onset_s : float or None
        The slip onset (``None``: it never slipped after the start).
    """

    FELL = "object_out_of_hand"
    """The reading that says the object fell: out of the hand now (no digit on it, away from
    where it sat). The environment's ``dropped`` latches instead: a lift earlier in the trial
    that left the object behind sets it for good (:class:`RisingLoad` reads it still, so
    its figures do not move)."""

    def __init__(self, lift_height_m: float, delay_s: float,
                 no_slip_s: float | None = None) -> None:
        self.lift_height_m = lift_height_m
        self.delay_s = delay_s
        self.no_slip_s = no_slip_s
        self.start_s: float | None = None
        self.onset_s: float | None = None
        self._top_s: float | None = None

    def watch(self, t_s: float, info: Mapping[str, Any]) -> bool:
        """Update from the readings ``info`` before the step at ``t_s``; True when the
        perturbation started at an earlier step (it acts now)."""
        touching = info["thumb_contact"] or info["finger_contact"]
        if self.start_s is None:
            if (self._top_s is None and touching
                    and info["wrist_height_m"] >= self.lift_height_m - 1e-6):
                self._top_s = t_s
            if (self._top_s is not None and t_s >= self._top_s + self.delay_s
                    and touching and not info["object_out_of_hand"]):
                self.start_s = t_s
            return False
        if self.onset_s is None and (
                (touching and info["slip_speed_m_s"] > SLIP_ONSET_M_S) or info[self.FELL]):
            self.onset_s = t_s
        return True

    @property
    def started(self) -> bool:
        """The perturbation started (the object was lifted and held)."""
        return self.start_s is not None

    def done(self, t_s: float, info: Mapping[str, Any]) -> bool:
        """The trial has its answer: dropped, or held for the recovery window after the
        onset; or (``no_slip_s``) not slipped that long after the start."""
        if self.onset_s is not None:
            return bool(info[self.FELL]) or t_s >= self.onset_s + RECOVERY_WINDOW_S
        return (self.no_slip_s is not None and self.start_s is not None
                and t_s >= self.start_s + self.no_slip_s)

    def recovered(self, info: Mapping[str, Any]) -> bool:
        """The object is still in the hand by the trial's last readings ``info``."""
        return not info[self.FELL]


class RisingLoad(HeldPerturbation):
    """A load that rises at ``rate_n_s`` (N/s) until the object slips, then stays (module
    notes); the trial's ``load`` hook. It reads the environment's latched ``dropped`` as
    before the opening existed (:attr:`HeldPerturbation.FELL`)."""

    FELL = "dropped"

    def __init__(self, lift_height_m: float, rate_n_s: float) -> None:
        super().__init__(lift_height_m, LOAD_DELAY_S)
        self.rate = rate_n_s
        self.load_n = 0.0

    def __call__(self, t_s: float, info: Mapping[str, Any]) -> float:
        """The load on the object at the step at ``t_s``, N."""
        if not self.watch(t_s, info):
            return 0.0
        if self.onset_s is None:
            self.load_n = self.rate * (t_s - self.start_s)
        return self.load_n


class Opening(HeldPerturbation):
    """An involuntary opening (module notes): from the start on, the hand's reference is
    the paradigm's minus ``fraction`` of the reference at the start, floored at 0; the
    trial's ``command`` hook.

    Parameters
    ----------
    lift_height_m : float
        The lift's height, m.
    fraction : float
        The fraction of the command lost, (0, 1].
    delay_s : float
        The opening comes at the first step this long after the top of the lift, s.

    Attributes
    ----------
    drop_n : float or None
        The reference lost at the start, N (``None`` before it).
    """

    def __init__(self, lift_height_m: float, fraction: float, delay_s: float) -> None:
        super().__init__(lift_height_m, delay_s, no_slip_s=RECOVERY_WINDOW_S)
        self.fraction = fraction
        self.drop_n: float | None = None

    def command(self, t_s: float, info: Mapping[str, Any], reference_n: float) -> float:
        """The hand's reference at the step at ``t_s`` from the paradigm's, N."""
        acting = self.watch(t_s, info)
        if self.start_s is None:
            return reference_n
        if not acting:  # the opening is now
            self.drop_n = self.fraction * reference_n
        return max(reference_n - self.drop_n, 0.0)


def perturbation_seed(seeds: Sequence[np.random.SeedSequence]) -> np.random.SeedSequence:
    """The trial's own stream for the perturbation's draws: the fourth child of the
    parent of the trial's ``seeds`` (the sEMG session, the environment and the operator
    are the first three; ``parent.spawn(4)[3]``, made without spawning, so no other
    stream moves)."""
    first = seeds[0]
    return np.random.SeedSequence(first.entropy, spawn_key=(*first.spawn_key[:-1], len(seeds)),
                                  pool_size=first.pool_size)


def perturbation_for(protocol: Any, lift_height_m: float,
                     seeds: Sequence[np.random.SeedSequence]
                     ) -> tuple[HeldPerturbation, TrialHooks]:
    """The perturbation ``protocol.perturbation`` names for one trial, and its hooks.

    Parameters
    ----------
    protocol : scenarios.schema.models.ProtocolConfig
        ``perturbation``, ``load_rate_n_s``, ``opening`` and ``opening_window_s``.
    lift_height_m : float
        The task's lift, m.
    seeds : sequence of SeedSequence
        The trial's seeds (``scenarios.runners.feedback_tasks.TaskSetup.trial_seqs``):
        the opening's time is drawn from :func:`perturbation_seed` of them.
    """
    if protocol.perturbation == "opening":
        rng = np.random.default_rng(perturbation_seed(seeds))
        delay_s = LOAD_DELAY_S + float(rng.uniform(0.0, protocol.opening_window_s))
        opening = Opening(lift_height_m, protocol.opening, delay_s)
        return opening, TrialHooks(command=opening.command, until=opening.done)
    load = RisingLoad(lift_height_m, protocol.load_rate_n_s)
    return load, TrialHooks(load=load, until=load.done)


def row_fields(protocol: Any, slipped: Sequence[HeldPerturbation]
               ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The row's fields of the perturbation: before the counts and after them.

    ``rising_load``: ``load_rate_n_s``; ``slip_load_n`` (mean load at the slip onsets of
    ``slipped``; as before the opening existed). ``opening``: ``perturbation``,
    ``opening``, ``opening_window_s``; ``drop_n`` (mean reference lost at the openings
    that made the object slip, N).
    """
    if protocol.perturbation == "opening":
        drops = [p.drop_n for p in slipped if getattr(p, "drop_n", None) is not None]
        return ({"perturbation": "opening", "opening": protocol.opening,
                 "opening_window_s": protocol.opening_window_s},
                {"drop_n": float(np.mean(drops)) if drops else None})
    loads = [p.load_n for p in slipped if isinstance(p, RisingLoad)]
    return ({"load_rate_n_s": protocol.load_rate_n_s},
            {"slip_load_n": float(np.mean(loads)) if loads else None})
