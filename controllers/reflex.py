"""Slip reflex: raise the force reference when the held object slips.

Commercial hands with slip sensing (e.g. Ottobock's SensorHand) tighten the
grip automatically when the object starts to slide; human reflexes respond in
20-300 ms (CALIBRATION.md). The reflex sits outside the force loop: it only
shapes the reference handed to the wrapped controller, so it does not change
the loop's margins (:meth:`SlipReflex.loop` is the wrapped controller's loop).

What it must not do (each seen in an earlier design of the reflex): fire when the
digits close on the object (the first pad pushes the object across the table,
which reads as slip), keep the grip high for the rest of the hold after one
transient slip, or raise the grip up to the force that breaks the object.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from controllers.base import Observation, as_observation
from sim.errors import GriploopError

if TYPE_CHECKING:
    import control


AUTO_GRIP = {"latency_s": 0.05, "gain": 0.3}
"""The hand's own slip response (``auto_grip``: bebionic "auto-grip", i-limb "auto-grasp",
SensorHand SUVA): this reflex with these settings, wrapped around whatever controller
runs. No published reaction time or grip step was found for the commercial responses
(CALIBRATION.md); the values are :class:`SlipReflex`'s defaults, chosen: a 50 ms sensor
and firmware latency, below the 74 ms of the human grip response to a slip (Johansson &
Westling 1987), and a step of 30 % of the reference per slip onset."""


class ReflexSpecError(GriploopError, ValueError):
    """A :class:`SlipReflex` parameter is out of range; the message says expected vs found."""


@dataclass(frozen=True)
class ReflexSpec:
    """The settings of a :class:`SlipReflex` (its law, in the class notes).

    A scenario's ``slip_reflex`` (and :data:`AUTO_GRIP`) sets some of them by name:
    ``ReflexSpec(**AUTO_GRIP)``.

    Attributes
    ----------
    latency_s : float
        Delay from slip detection to the boost, s (>= 0; rounded to whole periods).
    gain : float
        Boost added at each slip onset, as a fraction of the user's reference (>= 0):
        an isolated onset raises the reference from ``r`` to ``r * (1 + gain)``.
    slip_speed_threshold_m_s : float
        Tangential slip speed above which the armed grasp is slipping, m/s (> 0).
        Default 20 mm/s: on the MuJoCo hand a 0.3 kg can shaken at 4 Hz reads
        5-13 mm/s at the contacts every half cycle even when held at 1.7 times
        its slip force (creep of about 1 mm per cycle), while the slips that
        drop it read 50-300 mm/s; at 5 mm/s each shake cycle is an onset and
        the boost ratchets to ``max_boost``.
    arming_s : float
        Time both sides must have touched before slip can trigger, s (>= 0).
    decay_s : float
        Time constant of the exponential decay of the boost while no slip is
        detected, s (> 0; ``inf`` holds the boost).
    max_boost : float
        Cap on the boost (>= 0): the reference is raised at most to
        ``r * (1 + max_boost)``.
    distance_gain_per_m : float
        Extra boost per metre of slip while slip continues, 1/m (>= 0; 0 = onsets only).
    fragility_margin : float
        Fraction of the user's force limit kept free, in ``[0, 1)``.
    release_below_n : float
        A raw reference below this (N, >= 0) clears the reflex.
    """

    latency_s: float = 0.05
    gain: float = 0.3
    slip_speed_threshold_m_s: float = 0.02
    arming_s: float = 0.2
    decay_s: float = 1.0
    max_boost: float = 1.0
    distance_gain_per_m: float = 0.0
    fragility_margin: float = 0.2
    release_below_n: float = 0.5


def _check(name: str, value: float, ok: bool, expected: str) -> float:
    if not ok:
        raise ReflexSpecError(f"SlipReflex: expected {name} {expected}, found {value!r}")
    return float(value)


class SlipReflex:
    """Wraps a controller and boosts its force reference after measured slip.

    At each control step ``k`` (period ``dt_s``) with raw reference ``r`` (the
    user's, N) and observation ``obs``:

    1. **Clear.** If ``r < release_below_n`` (the user opens the hand) or
       neither ``obs.thumb_contact`` nor ``obs.finger_contact`` (contact lost):
       ``boost = 0``, the latency line is emptied and the reflex disarms; the
       output is ``r``.
    2. **Arm.** Until armed, a step without ``obs.both_sides`` restarts the
       count; at the ``n``-th consecutive step with ``both_sides`` the reflex
       arms if ``(n - 1) * dt_s >= arming_s``, and stays armed until cleared.
       So the closing contact (one side pushing the object across the table)
       never triggers it, while a slipping object whose contact flickers on
       one side during the hold (seen on the MuJoCo hand under shake) does.
    3. **Detect.** ``slip = armed and obs.slip_speed_m_s > slip_speed_threshold_m_s``
       (the tangential slip speed at the contacts; ``obs.slip_detected`` is not
       used). The pair ``(slip, obs.slip_speed_m_s)`` enters a delay line of
       ``L = round(latency_s / dt_s)`` steps; the boost update below uses the
       pair ``(s, v)`` detected ``L`` steps earlier.
    4. **Boost or decay** (``boost >= 0`` is dimensionless):

       - if ``s`` and the previous delayed sample was not slip (an onset):
         ``boost += gain``;
       - if ``s`` (onset or continuing slip):
         ``boost += distance_gain_per_m * v * dt_s`` (per metre of slip);
       - if not ``s``: ``boost *= exp(-dt_s / decay_s)``, so ``n`` steps
         without slip after a boost ``b`` leave ``b * exp(-n dt_s / decay_s)``;
       - then ``boost = min(boost, max_boost, ceiling / r - 1)`` (the last
         term only for ``r > 0`` and a finite ceiling), floored at 0: no
         wind-up above what the ceiling lets through.
    5. **Output.** With ``ceiling = (1 - fragility_margin) * max_force_n``::

           reference_out = max(r, min(r * (1 + boost), ceiling))

       The output never exceeds the ceiling unless the user's own ``r`` does,
       and then ``r`` passes unchanged: the reflex never lowers what the user
       asks for, and adds nothing above the ceiling.

    The ceiling bounds the reference; the measured force also carries the
    force loop's overshoot and the swings of a shaken object, which the margin
    must cover. Measured (``tests/controllers/test_reflex_shake.py``): a 0.3 kg
    can held at 3.5 N by a PI and shaken at 4 Hz, 10 mm, slips 55 mm without
    the reflex and 9 mm with it (one onset 0.25 s into the shake, boost 0.5,
    decayed to 0.16 at the end); peak force after the lift 6.1 N under a 7.2 N
    ceiling.

    Parameters
    ----------
    controller : object
        Controller with ``reset()``, ``act(observation)`` and ``loop(plant)``
        (and ``track(observation, u)`` if :meth:`track` is used).
    spec : ReflexSpec, optional
        Latency, gain, slip threshold, arming, decay, caps, fragility margin and
        release threshold (default ``ReflexSpec()``); kept as the reflex's
        attributes of the same names.
    dt_s : float
        Control period, s (> 0).
    max_force_n : float
        The user's force limit, N (> 0): the break force of a fragile object as
        the user sets it; ``inf`` (default) for a robust object.

    Attributes
    ----------
    boost : float
        Current boost (dimensionless).
    ceiling_n : float
        ``(1 - fragility_margin) * max_force_n``, N.
    latency_samples : int
        ``L``, the delay line length in control periods.
    n_onsets : int
        Slip onsets acted on (rising edges of the delayed slip signal) since :meth:`reset`.
    n_triggers : int
        Control steps on which delayed slip acted (onsets included).
    peak_boost : float
        Largest boost since :meth:`reset`.
    peak_reference_n : float
        Largest output reference since :meth:`reset`, N.
    first_onset_s : float or None
        ``obs.time_s`` at which the first acted-on onset was detected (before
        the latency), s.
    """

    def __init__(
        self,
        controller: Any,
        spec: ReflexSpec | None = None,
        *,
        dt_s: float,
        max_force_n: float = math.inf,
    ) -> None:
        r = ReflexSpec() if spec is None else spec
        latency_s, gain, arming_s, decay_s = r.latency_s, r.gain, r.arming_s, r.decay_s
        slip_speed_threshold_m_s, max_boost = r.slip_speed_threshold_m_s, r.max_boost
        distance_gain_per_m, fragility_margin = r.distance_gain_per_m, r.fragility_margin
        release_below_n = r.release_below_n
        self.controller = controller
        self.dt_s = _check("dt_s", dt_s, 0 < dt_s < math.inf, "> 0 s")
        self.latency_s = _check("latency_s", latency_s, 0 <= latency_s < math.inf, ">= 0 s")
        self.gain = _check("gain", gain, 0 <= gain < math.inf, ">= 0")
        self.slip_speed_threshold_m_s = _check(
            "slip_speed_threshold_m_s", slip_speed_threshold_m_s,
            0 < slip_speed_threshold_m_s < math.inf, "> 0 m/s")
        self.arming_s = _check("arming_s", arming_s, 0 <= arming_s < math.inf, ">= 0 s")
        self.decay_s = _check("decay_s", decay_s, decay_s > 0, "> 0 s")
        self.max_boost = _check("max_boost", max_boost, 0 <= max_boost < math.inf, ">= 0")
        self.distance_gain_per_m = _check(
            "distance_gain_per_m", distance_gain_per_m,
            0 <= distance_gain_per_m < math.inf, ">= 0 per m")
        self.max_force_n = _check("max_force_n", max_force_n, max_force_n > 0,
                                  "> 0 N (inf for no limit)")
        self.fragility_margin = _check("fragility_margin", fragility_margin,
                                       0 <= fragility_margin < 1, "in [0, 1)")
        self.release_below_n = _check("release_below_n", release_below_n,
                                      0 <= release_below_n < math.inf, ">= 0 N")
        self.ceiling_n = (1.0 - self.fragility_margin) * self.max_force_n
        self.latency_samples = int(round(self.latency_s / self.dt_s))
        # Steps of uninterrupted contact before arming: armed at the n-th with (n-1) dt >= arming_s.
        self._arm_steps = int(math.ceil(self.arming_s / self.dt_s - 1e-9)) + 1
        self._decay = math.exp(-self.dt_s / self.decay_s)
        self.name = f"{getattr(controller, 'name', 'controller')}+reflex"
        self.reset()

    # ------------------------------------------------------------------ state
    def _clear(self) -> None:
        self.boost = 0.0
        self._contact_steps = 0
        self._was_slipping = False
        self._line: deque[tuple[bool, float, float]] = deque()

    def reset(self) -> None:
        """Clear the boost, the latency line and the counters; reset the wrapped controller."""
        self._clear()
        self.n_onsets = 0
        self.n_triggers = 0
        self.peak_boost = 0.0
        self.peak_reference_n = 0.0
        self.first_onset_s: float | None = None
        self.controller.reset()

    @property
    def armed(self) -> bool:
        """Whether both sides have touched for ``arming_s`` since the last clear."""
        return self._contact_steps >= self._arm_steps

    def counters(self) -> dict[str, Any]:
        """Counters for an episode row: onsets, triggers, peak boost and reference, first onset."""
        return {"reflex_onsets": self.n_onsets, "reflex_triggers": self.n_triggers,
                "reflex_peak_boost": self.peak_boost,
                "reflex_peak_reference_n": self.peak_reference_n,
                "reflex_first_onset_s": self.first_onset_s}

    # ------------------------------------------------------------------ law
    def reference(self, obs: Observation) -> float:
        """Update the reflex from ``obs`` and return the output reference, N (see class doc)."""
        r = float(obs.reference_n)
        if r < self.release_below_n or not (obs.thumb_contact or obs.finger_contact):
            if self._contact_steps or self.boost:
                self._clear()
            self.peak_reference_n = max(self.peak_reference_n, r)
            return r
        if obs.both_sides:
            self._contact_steps += 1
        elif not self.armed:
            self._contact_steps = 0
        speed = float(obs.slip_speed_m_s)
        slipping = self.armed and speed > self.slip_speed_threshold_m_s
        line = self._line
        line.append((slipping, speed, float(obs.time_s)))
        if len(line) > self.latency_samples:
            s, v, t_detect = line.popleft()
        else:
            s, v, t_detect = False, 0.0, 0.0
        boost = self.boost
        if s:
            if not self._was_slipping:
                boost += self.gain
                self.n_onsets += 1
                if self.first_onset_s is None:
                    self.first_onset_s = t_detect
            boost += self.distance_gain_per_m * v * self.dt_s
            self.n_triggers += 1
        else:
            boost *= self._decay
        self._was_slipping = s
        cap = self.max_boost
        if r > 0 and self.ceiling_n < math.inf:
            cap = min(cap, self.ceiling_n / r - 1.0)
        boost = max(0.0, min(boost, cap))
        self.boost = boost
        self.peak_boost = max(self.peak_boost, boost)
        out = max(r, min(r * (1.0 + boost), self.ceiling_n))
        self.peak_reference_n = max(self.peak_reference_n, out)
        return out

    # ------------------------------------------------------------- interface
    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Update the reflex, then let the wrapped controller act on the boosted reference."""
        obs = as_observation(observation)
        return self.controller.act(replace(obs, reference_n=self.reference(obs)))

    def track(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """Update the reflex, and let the wrapped controller follow the applied command ``u``."""
        obs = as_observation(observation)
        self.controller.track(replace(obs, reference_n=self.reference(obs)), u)

    def loop(self, plant: control.LTI) -> control.LTI:
        """The wrapped controller's loop: the reflex shapes the reference only."""
        return self.controller.loop(plant)
