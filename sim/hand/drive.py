"""The hand's transmission: backdrivable, or self-locking as clinical hands are.

Clinical myoelectric hands hold what they grip when the motor stops: their
transmissions are self-locking (a Steeper worm nut "cannot be driven backwards"; a
Systemteknik hand holds force "indefinitely until it is opened voluntarily";
CALIBRATION.md, "Clinical hands and the published protocols"). griploop's spur
gearbox (``backdrivable``, the default) is pushed open by the object as soon as the
motor's torque falls; ``self_locking`` puts a worm stage in the drive.

**The worm stage** (the inclined-plane model of a worm and wheel: the thread is a screw
pushing the wheel's tooth; Childs, *Mechanical Design Engineering Handbook*, 2014,
chapter 11 "Worm gears", which names self-locking as the reason such sets are chosen
where a position must hold unpowered). With lead angle ``lambda`` and friction angle
``phi = atan(mu)``::

    forward efficiency  eta_f = tan(lambda) / tan(lambda + phi)   (motor drives the load)
    reverse efficiency  eta_r = tan(lambda - phi) / tan(lambda)   (load drives the motor)

The stage is self-locking when ``lambda < phi`` (``eta_r <= 0``: no torque from the load
side moves it, however large, within the gear's strength). :data:`SELF_LOCKING` uses a
single-start worm of lead angle 4 deg (single-start worms lock below a lead of about
5 deg, makers' rule) on a bronze or plastic wheel with ``mu = 0.10`` (lubricated steel on
bronze at low sliding speed is of the order of 0.05-0.15, and a worm at rest sees the
static, higher end): ``phi = 5.7 deg``, ``eta_f = 0.41``, ``eta_r = -0.43``. Gear-motor
makers call a worm unit self-locking when its efficiency is below 0.45 (SEVA-tec's gear
motor notes, 2.1.3); this one is. The parameters are chosen within these ranges, not
fitted to any outcome.

**What the simulation does with it** (:class:`sim.hand.grasp_env.GraspEnv`). The digits
move only where the motor drives them: while the command closes, they may close but not
open (the object cannot push them open); while it opens, they may open but not close,
and no faster than the motor turns the worm at that command's no-load speed (the
object's push does not drive a worm either way); with no command they are locked where
they stand, and the grip stays. Each digit's
joint carries a one-sided stop that follows it (a ratchet, updated at every control
step from its position then) with the stiffness of a gear tooth contact
(:attr:`DriveSpec.holding_solref`). The motor is sized for the same rated grip and
speed as the backdrivable hand (stall torque and no-load speed at the tendon unchanged:
clinical hands with self-locking drives grip 60-140 N and close in 0.4-1 s, Atzori &
Müller 2015): the worm's lower forward efficiency is paid in motor current, which the
current sensor reads (:func:`motor_for`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from sim.errors import GriploopError
from sim.hand.model import DRIVE_COEF, MotorSpec
from sim.registry import Registry


class UnknownDriveError(GriploopError, LookupError):
    """A drive that is not registered; the message lists the registered ones."""


class DriveSpecError(GriploopError, ValueError):
    """A drive's parameters do not make the transmission it claims."""


@dataclass(frozen=True)
class DriveSpec:
    """A transmission of the hand (module notes).

    Attributes
    ----------
    name : str
        Registered name.
    self_locking : bool
        The load cannot drive the transmission: the digits move only under motor torque.
    lead_angle_deg : float or None
        Worm lead angle, deg (``None``: no worm stage).
    friction_coef : float or None
        Worm-wheel friction coefficient (``None``: no worm stage).
    holding_solref, holding_solimp : tuple of float
        MuJoCo ``solref`` (time constant s, damping ratio) and ``solimp`` of the stop
        that holds a locked digit: the worm's tooth contact, as stiff as the physics
        resolves it (a held grip loses under 1 % to the stop's compliance when the
        motor's torque falls to zero: ``tests/sim/test_drive.py``).
    """

    name: str
    self_locking: bool = False
    lead_angle_deg: float | None = None
    friction_coef: float | None = None
    holding_solref: tuple[float, float] = (0.004, 1.0)
    holding_solimp: tuple[float, float, float] = (0.999, 0.9999, 0.0001)

    def __post_init__(self) -> None:
        if self.self_locking and not self.worm_reverse_efficiency <= 0.0:
            raise DriveSpecError(
                f"drive {self.name}: a self-locking worm needs a lead angle below the "
                f"friction angle (reverse efficiency <= 0); found lead "
                f"{self.lead_angle_deg} deg, friction angle "
                f"{math.degrees(math.atan(self.friction_coef or 0.0)):.2f} deg")

    @property
    def friction_angle_deg(self) -> float | None:
        """``atan(mu)``, deg."""
        return None if self.friction_coef is None else math.degrees(math.atan(self.friction_coef))

    @property
    def worm_forward_efficiency(self) -> float:
        """``tan(lambda) / tan(lambda + phi)`` (1 without a worm stage)."""
        if self.lead_angle_deg is None or self.friction_coef is None:
            return 1.0
        lam, phi = math.radians(self.lead_angle_deg), math.atan(self.friction_coef)
        return math.tan(lam) / math.tan(lam + phi)

    @property
    def worm_reverse_efficiency(self) -> float:
        """``tan(lambda - phi) / tan(lambda)`` (1 without a worm stage; <= 0 locks)."""
        if self.lead_angle_deg is None or self.friction_coef is None:
            return 1.0
        lam, phi = math.radians(self.lead_angle_deg), math.atan(self.friction_coef)
        return math.tan(lam - phi) / math.tan(lam)

    def summary(self) -> dict[str, object]:
        """JSON-ready parameters and derived efficiencies."""
        return {"name": self.name, "self_locking": self.self_locking,
                "lead_angle_deg": self.lead_angle_deg, "friction_coef": self.friction_coef,
                "worm_forward_efficiency": self.worm_forward_efficiency,
                "worm_reverse_efficiency": self.worm_reverse_efficiency}


BACKDRIVABLE = DriveSpec("backdrivable")
"""Today's spur gearbox (:class:`sim.hand.model.MotorSpec`, 250:1 at 85 %)."""
SELF_LOCKING = DriveSpec("self_locking", self_locking=True, lead_angle_deg=4.0,
                         friction_coef=0.10)
"""A worm stage of lead angle 4 deg and friction coefficient 0.10 (module notes)."""

_DRIVES = Registry("drive", UnknownDriveError)


def register_drive(spec: DriveSpec, *, replace: bool = False) -> None:
    """Register a transmission under ``spec.name``."""
    _DRIVES.register(spec.name, spec, replace=replace)


unregister_drive, drive_names = _DRIVES.functions(__name__, "drive")


def make_drive(drive: str | DriveSpec) -> DriveSpec:
    """The registered drive ``drive`` (or ``drive`` itself if a :class:`DriveSpec`).

    Raises
    ------
    UnknownDriveError
        An unknown name; the message lists the registered drives.
    """
    return drive if isinstance(drive, DriveSpec) else _DRIVES.get(drive)


def motor_for(drive: DriveSpec, motor: MotorSpec) -> MotorSpec:
    """``motor`` as sized for ``drive``: the same stall torque and no-load speed at the
    tendon, the worm's forward efficiency paid by a stronger motor (module notes)."""
    eta = drive.worm_forward_efficiency
    if eta == 1.0:
        return motor
    return replace(motor, efficiency=motor.efficiency * eta,
                   stall_torque_nm=motor.stall_torque_nm / eta)


class DigitLock:
    """A self-locking drive on a built hand: each digit moves only where the motor drives it.

    Each digit's joint range is a pair of stops moved once per control step
    (:meth:`step`). Closing: the opening stop follows the digit up (the object cannot
    push it open); opening: the closing stop follows it down, and the opening stop is
    where the motor turning the worm at the command's no-load speed takes it in one
    period (the object's push cannot open it faster: the load does not drive a worm); no
    command: both stops where it stands. The stops have the drive's holding stiffness.

    Parameters
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The hand (``model``'s joint ranges and limit parameters are changed).
    drive : DriveSpec
        A self-locking drive.
    motor : MotorSpec
        The motor as sized for it (:func:`motor_for`).
    control_dt_s : float
        Control period, s.
    joints : sequence of str
        The digits' joints.
    """

    def __init__(self, model: Any, data: Any, drive: DriveSpec, motor: MotorSpec,
                 control_dt_s: float, joints: tuple[str, ...] = ("index", "middle", "thumb"),
                 ) -> None:
        self.data = data
        self.joints = [model.joint(n).id for n in joints]
        self.qpos_adr = [int(model.jnt_qposadr[j]) for j in self.joints]
        self.ranges = [tuple(model.jnt_range[j].tolist()) for j in self.joints]
        self._jnt_range = model.jnt_range  # a view, fetched once
        # the coupled digit angle's no-load speed per unit of command, times the period
        self.opening_per_command = (motor.output_no_load_speed_rad_s
                                    / sum(DRIVE_COEF.values()) * control_dt_s)
        for j in self.joints:
            model.jnt_solref[j] = drive.holding_solref
            model.jnt_solimp[j, :3] = drive.holding_solimp
        self._held: list[list[float]] | None = None

    def reset(self) -> None:
        """The digits free within their joint ranges (an episode's start)."""
        for j, rng in zip(self.joints, self.ranges, strict=True):
            self._jnt_range[j] = rng
        self._held = None

    def step(self, u: float) -> None:
        """Move the stops for a control period at command ``u`` (-1..1)."""
        q, ranges = self.data.qpos, self._jnt_range
        held = self._held
        if held is None:
            held = self._held = [[lo, hi] for lo, hi in self.ranges]
        for stop, j, adr, (lo0, hi0) in zip(held, self.joints, self.qpos_adr, self.ranges,
                                            strict=True):
            now = q.item(adr)
            if u > 0.0:
                stop[0], stop[1] = max(stop[0], now), hi0
            elif u < 0.0:
                # from the stop the digit rests on (not the position it sank to under the
                # stop's compliance, which would add up over the steps)
                at = max(min(now, stop[1]), stop[0])
                stop[0] = max(lo0, at + u * self.opening_per_command)
                stop[1] = min(stop[1], now)
            else:
                stop[0], stop[1] = (max(stop[0], min(now, stop[1])),
                                    min(stop[1], max(now, stop[0])))
            ranges[j] = stop


register_drive(BACKDRIVABLE)
register_drive(SELF_LOCKING)
