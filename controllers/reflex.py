"""Slip reflex: raise the force reference when the object slips.

Commercial hands with slip sensing (e.g. Ottobock's SensorHand) tighten the
grip automatically when the object starts to slide; human reflexes respond in
20-300 ms (CALIBRATION.md). The reflex sits outside the force loop: it only
shapes the reference handed to the wrapped controller, so it does not change
the loop's margins.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import control
import numpy as np

from controllers.base import Observation, as_observation


class SlipReflex:
    """Wraps a controller and adds a reference boost that grows while slip is detected.

    The slip signal (detector flag, or slip speed above a threshold) passes
    through a delay line of ``latency_s``. On each delayed slip sample the
    boost increases by ``step_n + speed_gain_n_s_per_m * slip_speed_m_s`` (N),
    up to ``max_boost_n``; it is held (not
    decayed) while the user keeps holding, and cleared when the user's
    reference drops below ``release_below_n`` (the hand is being opened).
    The boosted reference is limited to ``max_reference_n`` (the fragility limit).

    Parameters
    ----------
    controller : object
        Any controller with ``reset()``, ``act(observation)`` and ``loop(plant)``.
    dt_s : float
        Control period in seconds.
    latency_s : float
        Delay from slip onset to the first boost, s (rounded to whole periods).
    step_n : float
        Boost added per delayed slip sample, N.
    speed_gain_n_s_per_m : float
        Extra boost per m/s of slip speed per sample, N s/m.
    max_boost_n : float
        Largest total boost, N.
    release_below_n : float
        The boost is cleared when the raw reference falls below this, N.
    max_reference_n : float
        Ceiling on the boosted reference, N.
    slip_speed_threshold_m_s : float
        Slip speed counted as slipping even without the detector flag, m/s.
    onset_fraction : float
        Extra boost at each slip onset (a rising edge of the delayed slip
        signal), as a fraction of the current reference: one slip event raises
        the grip by ``onset_fraction`` of what the user asks for.
    """

    def __init__(
        self,
        controller: Any,
        *,
        dt_s: float,
        latency_s: float = 0.05,
        step_n: float = 0.5,
        speed_gain_n_s_per_m: float = 0.0,
        max_boost_n: float = 10.0,
        release_below_n: float = 0.5,
        max_reference_n: float = float("inf"),
        slip_speed_threshold_m_s: float = float("inf"),
        onset_fraction: float = 0.0,
    ) -> None:
        if dt_s <= 0:
            raise ValueError(f"SlipReflex: expected dt_s > 0, found {dt_s}")
        if latency_s < 0:
            raise ValueError(f"SlipReflex: expected latency_s >= 0, found {latency_s}")
        if min(step_n, speed_gain_n_s_per_m, max_boost_n, onset_fraction) < 0:
            raise ValueError(
                "SlipReflex: expected non-negative step_n, speed_gain_n_s_per_m, max_boost_n and "
                f"onset_fraction, found {step_n}, {speed_gain_n_s_per_m}, {max_boost_n}, "
                f"{onset_fraction}"
            )
        self.controller = controller
        self.dt_s = float(dt_s)
        self.latency_s = float(latency_s)
        self.latency_samples = int(round(latency_s / dt_s))
        self.step_n = float(step_n)
        self.speed_gain_n_s_per_m = float(speed_gain_n_s_per_m)
        self.max_boost_n = float(max_boost_n)
        self.release_below_n = float(release_below_n)
        self.max_reference_n = float(max_reference_n)
        self.slip_speed_threshold_m_s = float(slip_speed_threshold_m_s)
        self.onset_fraction = float(onset_fraction)
        self.name = f"{getattr(controller, 'name', 'controller')}+reflex"
        self.reset()

    def reset(self) -> None:
        """Clear the boost and the latency line, and reset the wrapped controller."""
        self.boost_n = 0.0
        self.n_triggers = 0
        self.n_onsets = 0
        self._was_slipping = False
        self._line: deque[tuple[bool, float]] = deque(
            [(False, 0.0)] * self.latency_samples, maxlen=self.latency_samples + 1
        )
        self.controller.reset()

    def reference(self, obs: Observation) -> float:
        """Update the boost from this observation and return the boosted reference in N."""
        slipping = bool(obs.slip_detected) or obs.slip_speed_m_s >= self.slip_speed_threshold_m_s
        self._line.append((slipping, float(obs.slip_speed_m_s)))
        delayed, speed = self._line.popleft()
        if obs.reference_n < self.release_below_n:
            self.boost_n = 0.0
        elif delayed:
            self.n_triggers += 1
            increment = self.step_n + self.speed_gain_n_s_per_m * abs(speed)
            if not self._was_slipping:
                self.n_onsets += 1
                increment += self.onset_fraction * obs.reference_n
            self.boost_n = min(self.boost_n + increment, self.max_boost_n)
        self._was_slipping = delayed
        return float(np.minimum(obs.reference_n + self.boost_n, self.max_reference_n))

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """Boost the reference, then let the wrapped controller act on it."""
        obs = as_observation(observation)
        return self.controller.act(replace(obs, reference_n=self.reference(obs)))

    def loop(self, plant: control.LTI) -> control.LTI:
        """The wrapped controller's loop: the reflex shapes the reference only."""
        return self.controller.loop(plant)
