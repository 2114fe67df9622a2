"""The observation a controller acts on, shared by every controller.

The action a controller returns is a normalized motor command in ``-1..1``
(positive closes the hand), the input of the linearized plant.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

if TYPE_CHECKING:
    import control

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
    thumb_contact, finger_contact : bool, default False
        Whether the thumb side and the finger side touch the object (a pad
        force sensor reading above its noise floor).
    finger_position_rad : float, default 0.0
        Finger joint encoder, rad (0 = straight down, + closes).
    load_force_n : float, default 0.0
        Tangential load the digits carry (three-axis fingertip sensors), N.
    lift_force_n : float, default 0.0
        Upward force the hand applies to the object (a wrist load cell less
        the hand's own weight), N: the carried weight once lifted.
    """

    time_s: float
    reference_n: float
    grip_force_n: float
    finger_velocity: float = 0.0
    slip_detected: bool = False
    slip_speed_m_s: float = 0.0
    thumb_contact: bool = False
    finger_contact: bool = False
    finger_position_rad: float = 0.0
    load_force_n: float = 0.0
    lift_force_n: float = 0.0

    @property
    def both_sides(self) -> bool:
        """Whether both sides of the hand touch the object (the grasp is closed)."""
        return self.thumb_contact and self.finger_contact


_FIELDS = tuple(f.name for f in fields(Observation))
_REQUIRED = ("time_s", "reference_n", "grip_force_n")


def observation_from_info(info: Mapping[str, Any], reference_n: float, *,
                          slip_speed_threshold_m_s: float = 0.005) -> Observation:
    """The observation a prosthesis has after a :class:`sim.hand.grasp_env.GraspEnv` step.

    Parameters
    ----------
    info : mapping
        ``GraspEnv`` step ``info`` (grip force, contact flags, finger encoder,
        load and slip readings).
    reference_n : float
        Grip-force reference in N.
    slip_speed_threshold_m_s : float
        Slip speed above which ``slip_detected`` is set, m/s.
    """
    slip = float(info["slip_speed_m_s"])
    return Observation(
        time_s=float(info["time_s"]), reference_n=float(reference_n),
        grip_force_n=float(info["grip_force_n"]),
        finger_velocity=float(info["finger_velocity_rad_s"]),
        slip_detected=slip > slip_speed_threshold_m_s, slip_speed_m_s=slip,
        thumb_contact=bool(info.get("thumb_contact", False)),
        finger_contact=bool(info.get("finger_contact", False)),
        finger_position_rad=float(info["finger_position_rad"]),
        load_force_n=float(info["load_force_n"]),
        lift_force_n=float(info.get("lift_force_n", 0.0)),
    )


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


@runtime_checkable
class Controller(Protocol):
    """What every force controller provides (PID, lead-lag, MPC, scheduled banks, wrappers).

    Attributes
    ----------
    dt_s : float
        Control period, s.
    """

    dt_s: float

    def reset(self, u0: float = 0.0) -> None:
        """Return to the initial state with the command ``u0`` (-1..1) applied."""

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """The motor command (-1..1) for this control step."""

    def loop(self, plant: control.LTI) -> control.LTI:
        """Open loop ``C P z**-d`` with sample-and-hold and computation delay."""


def controller_stats(controller: object) -> dict[str, float]:
    """Run-time counters of a controller (e.g. the MPC's QP solves and failures).

    A controller reports them with a ``stats() -> dict`` method; one without
    reports none (``{}``).
    """
    stats = getattr(controller, "stats", None)
    return dict(stats()) if callable(stats) else {}
