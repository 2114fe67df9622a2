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
class Implementation:
    """How a designed controller runs on the hand: its period, its delay and its command range.

    Shared by the designs (:func:`~controllers.pid.design_pid`,
    :func:`~controllers.lead_lag.design_lead_lag`, :class:`~controllers.mpc.MPC`) and the
    :class:`~controllers.pid.PID` they build; the loop analysis includes the delay.

    Attributes
    ----------
    dt_s : float or None
        Control period, s; ``None``: the discrete design plant's (required for a
        continuous plant, and by a :class:`~controllers.pid.PID` built directly).
    computation_delay_samples : int
        Whole control periods between measuring the force and applying the command.
    u_limits : (float, float)
        Command saturation, normalized motor command (default ``(-1, 1)``).
    """

    dt_s: float | None = None
    computation_delay_samples: int = 1
    u_limits: tuple[float, float] = COMMAND_LIMITS


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

    Only these are required; :class:`ControllerBase` gives working defaults for
    the rest (``track``, ``handover``, ``computation_delay_samples``) and
    :func:`complete_controller` adds them to a design that lacks them.

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


#: What a controller must define itself; everything else has a working default.
REQUIRED_METHODS = ("reset", "act", "loop")


class ControllerBase:
    """Working defaults for what scheduling, hand-over and loop analysis ask of a design.

    A controller needs only ``reset``, ``act`` and ``loop`` (:class:`Controller`).
    The gain schedule (:class:`controllers.schedule.ScheduledController`) and
    the approach (:class:`controllers.approach.ContactGate`) also call
    ``track`` (follow a command someone else applied) and ``handover`` (take
    over at a command). Their defaults restart the controller with that command
    applied, ``reset(u)``: a controller whose internal state cannot be
    conditioned on the applied command then starts from it, which is bumpless
    for any design whose ``reset(u0)`` seeds its output (an integrator) and
    harmless for a static one. Designs with states that can follow the loop
    (PID, lead-lag, MPC) override both.

    Attributes
    ----------
    computation_delay_samples : int
        Periods between the observation and the command reaching the hand:
        1, as :class:`controllers.drive.HandLoop` applies it.
    """

    computation_delay_samples: int = 1

    def reset(self, u0: float = 0.0) -> None:  # pragma: no cover - the subclass defines it
        raise NotImplementedError

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """Follow the command ``applied_u`` another controller applied: restart from it."""
        self.reset(float(applied_u))

    def handover(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """Take over the loop at command ``u``: restart from it."""
        self.reset(float(u))


class CompletedController(ControllerBase):
    """A controller with only ``reset``, ``act`` and ``loop``, completed by :class:`ControllerBase`.

    Attributes it lacks come from :class:`ControllerBase`; everything else
    (``stats``, gains, ``report_``) is read from the wrapped controller.

    Parameters
    ----------
    inner : object
        The designed controller.
    dt_s : float
        Control period, s, used when ``inner`` has no ``dt_s``.
    """

    def __init__(self, inner: Any, dt_s: float) -> None:
        self.inner = inner
        self.dt_s = float(getattr(inner, "dt_s", dt_s))
        self.computation_delay_samples = int(getattr(inner, "computation_delay_samples", 1))

    def reset(self, u0: float = 0.0) -> None:
        """``inner.reset(u0)``."""
        self.inner.reset(u0)

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """``inner.act(observation)``."""
        return float(self.inner.act(observation))

    def loop(self, plant: control.LTI) -> control.LTI:
        """``inner.loop(plant)``."""
        return self.inner.loop(plant)

    def track(self, observation: Observation | Mapping[str, Any], applied_u: float) -> None:
        """``inner.track`` if it has one, else the default (restart from ``applied_u``)."""
        (getattr(self.inner, "track", None) or super().track)(observation, applied_u)

    def handover(self, observation: Observation | Mapping[str, Any], u: float) -> None:
        """``inner.handover`` if it has one, else the default (restart from ``u``)."""
        (getattr(self.inner, "handover", None) or super().handover)(observation, u)

    def __getattr__(self, name: str) -> Any:
        if name == "inner":  # not set yet (copying, unpickling)
            raise AttributeError(name)
        return getattr(self.inner, name)


def complete_controller(controller: Any, dt_s: float, *, kind: str = "controller") -> Any:
    """``controller`` with everything a schedule and an episode call on it.

    Parameters
    ----------
    controller : object
        What a registered design function returned.
    dt_s : float
        Control period of the design plant, s (for a controller without ``dt_s``).
    kind : str
        Registered name, for the message.

    Returns
    -------
    object
        ``controller`` itself when it already has ``track``, ``handover``,
        ``dt_s`` and ``computation_delay_samples``; else a :class:`CompletedController`.

    Raises
    ------
    controllers.errors.SpecificationError
        ``controller`` lacks one of :data:`REQUIRED_METHODS`.
    """
    from controllers.errors import SpecificationError

    missing = [m for m in REQUIRED_METHODS if not callable(getattr(controller, m, None))]
    if missing:
        raise SpecificationError(
            f"{kind}: its design returned a {type(controller).__name__} without "
            f"{', '.join(missing)} (a controller defines {', '.join(REQUIRED_METHODS)})")
    complete = all(callable(getattr(controller, m, None)) for m in ("track", "handover")) and all(
        hasattr(controller, a) for a in ("dt_s", "computation_delay_samples"))
    return controller if complete else CompletedController(controller, dt_s)


def controller_stats(controller: object) -> dict[str, float]:
    """Run-time counters of a controller (e.g. the MPC's QP solves and failures).

    A controller reports them with a ``stats() -> dict`` method; one without
    reports none (``{}``).
    """
    stats = getattr(controller, "stats", None)
    return dict(stats()) if callable(stats) else {}
