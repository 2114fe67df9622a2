"""The observation a controller acts on, shared by every controller.

The action a controller returns is a normalized motor command in ``-1..1``
(positive closes the hand), the input of the linearized plant.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

COMMAND_LIMITS = (-1.0, 1.0)


@dataclass(frozen=True)
class Observation:
    """What the prosthesis knows at one control step.

    Parameters
    ----------
    time_s : float
        Time of the sample in seconds.
    reference_n : float
        Grip-force reference in newtons (the estimator's output, held between updates).
    grip_force_n : float
        Measured grip force in newtons.
    finger_velocity : float, default 0.0
        Finger closing velocity in the environment's unit (rad/s of the finger joint);
        informative only, no controller here needs it.
    slip_detected : bool, default False
        Whether a slip detector flags the object as slipping at this step.
    slip_speed_m_s : float, default 0.0
        Tangential slip speed of the object relative to the pads in m/s.
    """

    time_s: float
    reference_n: float
    grip_force_n: float
    finger_velocity: float = 0.0
    slip_detected: bool = False
    slip_speed_m_s: float = 0.0


_FIELDS = tuple(f.name for f in fields(Observation))
_REQUIRED = ("time_s", "reference_n", "grip_force_n")


def as_observation(obs: Observation | Mapping[str, Any]) -> Observation:
    """Accept an :class:`Observation` or a mapping with the same keys.

    Raises
    ------
    KeyError
        If a mapping lacks ``time_s``, ``reference_n`` or ``grip_force_n``.
    """
    if isinstance(obs, Observation):
        return obs
    missing = [k for k in _REQUIRED if k not in obs]
    if missing:
        raise KeyError(
            f"observation: expected keys {list(_REQUIRED)}, missing {missing} "
            f"(found {sorted(obs)})"
        )
    return Observation(**{k: obs[k] for k in _FIELDS if k in obs})
