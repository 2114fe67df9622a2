"""The MuJoCo prosthetic hand: motor model, model assembly with an object, ids.

The hand (``sim/hand/assets/hand.xml``) is a single-drive myoelectric hand: one DC
motor and gearbox close a thumb opposing two rigidly coupled fingers (index and
middle), the layout of single-motor hands such as the Michelangelo or the
Ottobock SensorHand. The gearbox output drives a fixed tendon
``L = 0.5 q_index + 0.5 q_middle + q_thumb`` (rad), so the thumb receives twice
the finger torque and balances the two fingers.

Motor model (DC motor, inductance neglected, normalized armature voltage
``u`` in -1..1)::

    i   = i_stall (u - omega_m / omega_0)           armature current (A)
    tau = eta G k_t i = tau_stall_out (u - v / v_0)  output torque on the tendon (N m)

with ``omega_m = G v`` the motor speed and ``v`` the tendon speed. In MuJoCo
this is a ``general`` actuator with gain ``tau_stall_out`` and velocity bias
``-tau_stall_out / v_0``; the current is read back from the actuator force.
Defaults (see :class:`MotorSpec`) give a free full close in about 0.6 s and a
stall grip force near 100 N (CALIBRATION.md, "Prosthetic hands").

Fingertip pads (see :class:`PadSpec`): each pad geom sits on a slide joint
along the pad normal with a spring and a damper over a few millimetres of
travel, then a stiff stop (the phalanx). This is the silicone of a real
fingertip. It matters at first contact: the drive's rotor inertia reflected
through the gearbox (``J G^2``) is about 4 kg at an 80 mm lever, and a rigid
fingertip stops it within one or two physics steps: an impact of tens of
newtons even at a gentle closing command. The pad spreads the stop over tens
of milliseconds, so the force rises at about ``k v`` (pad stiffness times
closing speed) instead, until the pad bottoms out (docs/HAND.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from typing import ClassVar

import mujoco
import numpy as np

from sim.hand.errors import HandSpecError
from sim.hand.objects import ObjectSpec

HAND_XML = "hand.xml"
#: Fingertip pad slide joints (+ towards the object), one per digit, as in hand.xml.
PAD_JOINTS = ("thumb_pad", "index_pad", "middle_pad")
WRIST_ACTUATORS = ("wrist_x", "wrist_y", "wrist_z")
#: Tendon coefficients of the drive (index, middle, thumb), as in hand.xml.
DRIVE_COEF = {"index": 0.5, "middle": 0.5, "thumb": 1.0}
#: Distance from a digit hinge to the middle of its pad (m), the grip lever arm.
PAD_LEVER_M = 0.08
FINGER_LENGTH_M = 0.1
HINGE_BELOW_PALM_M = 0.012


@dataclass(frozen=True)
class MotorSpec:
    """DC motor and gearbox of the hand drive.

    Parameters
    ----------
    stall_torque_nm : float
        Motor stall torque at full command, N m (motor shaft).
    no_load_speed_rad_s : float
        Motor no-load speed at full command, rad/s (motor shaft).
    gear_ratio : float
        Gearbox reduction (motor turns per output turn).
    efficiency : float
        Gearbox efficiency, 0..1.
    torque_constant_nm_a : float
        Motor torque constant k_t in N m / A (equal to the back-EMF constant in SI).
    rotor_inertia_kg_m2 : float
        Rotor inertia in kg m^2; reflected to the digits as joint armature ``J G^2``.

    Notes
    -----
    Defaults: 0.04 N m stall, 1480 rad/s no load (7.4 V with k_t = 5 mN m/A,
    i.e. an 8 A stall current from a 2-cell Li-ion pack), 250:1 gearbox at 85 %:
    8.5 N m stall at the tendon, i.e. about 106 N on an 80 mm thumb lever, and a
    free tendon speed of 5.9 rad/s: the digits sweep 1.65 rad in about 0.6 s.
    The rotor inertia, 1e-7 kg m^2 (1 g cm^2), is the order of a 16 mm,
    15 W DC motor; reflected through 250:1 it is 6.25e-3 kg m^2 on the tendon,
    0.025 kg m^2 on the coupled digit angle (the tendon moves 2 rad per rad),
    i.e. about 4 kg at an 80 mm lever.
    """

    stall_torque_nm: float = 0.04
    no_load_speed_rad_s: float = 1480.0
    gear_ratio: float = 250.0
    efficiency: float = 0.85
    torque_constant_nm_a: float = 0.005
    rotor_inertia_kg_m2: float = 1e-7

    def __post_init__(self) -> None:
        for name in ("stall_torque_nm", "no_load_speed_rad_s", "gear_ratio",
                     "torque_constant_nm_a", "rotor_inertia_kg_m2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise HandSpecError(
                    f"MotorSpec.{name}: expected a positive number, found {value!r}")
        if not 0 < self.efficiency <= 1:
            raise HandSpecError(
                f"MotorSpec.efficiency: expected 0 < eta <= 1, found {self.efficiency}"
            )

    @property
    def output_stall_torque_nm(self) -> float:
        """Stall torque at the gearbox output (tendon), N m."""
        return self.stall_torque_nm * self.gear_ratio * self.efficiency

    @property
    def output_no_load_speed_rad_s(self) -> float:
        """No-load speed at the gearbox output (tendon), rad/s."""
        return self.no_load_speed_rad_s / self.gear_ratio

    @property
    def stall_current_a(self) -> float:
        """Armature current at stall and full command, A."""
        return self.stall_torque_nm / self.torque_constant_nm_a

    @property
    def supply_voltage_v(self) -> float:
        """Armature voltage at full command, V (``k_e omega_0``)."""
        return self.torque_constant_nm_a * self.no_load_speed_rad_s

    @property
    def max_grip_force_n(self) -> float:
        """Stall grip force on the thumb side at the nominal pad lever, N."""
        return self.output_stall_torque_nm * DRIVE_COEF["thumb"] / PAD_LEVER_M

    def current_a(self, actuator_force_nm: float | np.ndarray) -> float | np.ndarray:
        """Armature current in A from the actuator (tendon) force in N m."""
        return actuator_force_nm / (self.efficiency * self.gear_ratio * self.torque_constant_nm_a)


@dataclass(frozen=True)
class PadSpec:
    """Compliant silicone fingertip pads.

    Each pad is a body on a slide joint along its normal: a linear spring and
    damper over ``travel_m``, then a stop at the rigid phalanx (a joint limit
    with stiff constraint parameters). The pad is soft at first touch and
    stiffens when it bottoms out, like a silicone fingertip. The thumb pad
    opposes both fingers, so it gets their combined stiffness and damping
    (``thumb_scale`` times a finger pad's): both sides of the grasp are then
    equally compliant and bottom out at the same grip force.

    Parameters
    ----------
    stiffness_n_m : float
        Spring stiffness of a finger pad, N/m.
    damping_n_s_m : float
        Damping of a finger pad, N s/m (silicone is lossy: the defaults give
        damping ratios of 0.4 (15 g finger pads) and 0.5 (20 g thumb pad)).
    travel_m : float
        Compression at which a pad bottoms out, m (the same on all digits).

    Notes
    -----
    Defaults: 1 N/mm over 4 mm per finger pad, 2 N/mm on the thumb, so each
    side of the grasp bottoms out at 8 N; human finger pulp and silicone
    fingertips are of the order of 1-10 N/mm and stiffen with load. First
    contacts and fragile grasps (egg, cup: below 5 N) stay on the springs; a
    grasp at 10 N or more sits on the stops, as stiff as a rigid fingertip.
    The spring is integrated explicitly: :func:`build_spec` checks
    ``omega dt <= 1`` with ``omega = sqrt(k / m_pad)`` for every pad.
    """

    stiffness_n_m: float = 1000.0
    damping_n_s_m: float = 3.0
    travel_m: float = 0.004

    #: Thumb pad stiffness and damping relative to a finger pad's.
    thumb_scale: ClassVar[float] = DRIVE_COEF["thumb"] / DRIVE_COEF["index"]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.stiffness_n_m) and self.stiffness_n_m > 0):
            raise HandSpecError(
                f"PadSpec.stiffness_n_m: expected a positive stiffness in N/m, found "
                f"{self.stiffness_n_m!r}"
            )
        if not (math.isfinite(self.damping_n_s_m) and self.damping_n_s_m >= 0):
            raise HandSpecError(
                f"PadSpec.damping_n_s_m: expected a damping >= 0 in N s/m, found "
                f"{self.damping_n_s_m!r}"
            )
        if not (math.isfinite(self.travel_m) and 0 < self.travel_m <= 0.01):
            raise HandSpecError(
                f"PadSpec.travel_m: expected 0 < travel <= 0.01 m, found {self.travel_m!r}"
            )

    def joint_stiffness_n_m(self, joint: str) -> float:
        """Spring stiffness of pad joint ``joint`` (one of ``PAD_JOINTS``), N/m."""
        return self.stiffness_n_m * self._scale(joint)

    def joint_damping_n_s_m(self, joint: str) -> float:
        """Damping of pad joint ``joint`` (one of ``PAD_JOINTS``), N s/m."""
        return self.damping_n_s_m * self._scale(joint)

    def _scale(self, joint: str) -> float:
        if joint not in PAD_JOINTS:
            raise LookupError(f"pad joint: expected one of {PAD_JOINTS}, found {joint!r}")
        return self.thumb_scale if joint == "thumb_pad" else 1.0

    @property
    def bottom_out_force_n(self) -> float:
        """Grip force (one side of the grasp) at which the pads bottom out, N."""
        return self.thumb_scale * self.stiffness_n_m * self.travel_m


#: x of the point midway between the thumb pad surface (hinge at -0.06 m, radius
#: 0.011 m) and the finger pad surfaces (hinges at +0.06 m, radius 0.010 m), m.
GRASP_CENTRE_X_M = 0.5 * ((-0.06 + 0.011) + (0.06 - 0.010))


#: Fingertip clearance over the table of straight digits at the approach pose, m; and the
#: least one, where the hand comes down to meet a small object's sides (approach_height_m).
TABLE_CLEARANCE_M = 0.01
SMALL_OBJECT_CLEARANCE_M = 0.001
#: x of the finger hinges (the thumb's is at -x), and the pads' radii, m (hand.xml).
FINGER_HINGE_X_M = 0.06
FINGER_PAD_RADIUS_M = 0.010
THUMB_PAD_RADIUS_M = 0.011


def fingertip_meet_depth_m(obj: ObjectSpec) -> float:
    """How far below the hinge line the fingertips are when they meet the object's side, m.

    A fingertip (the round end of its pad, ``FINGER_LENGTH_M`` from the hinge) reaches the
    side of a box or an upright cylinder, ``width_m / 2`` from the grasp centre, at the
    digit angle ``asin((hinge x - centre - half width - pad radius) / length)``.
    """
    reach_m = FINGER_HINGE_X_M - GRASP_CENTRE_X_M - 0.5 * obj.width_m - FINGER_PAD_RADIUS_M
    sin_angle = min(max(reach_m / FINGER_LENGTH_M, -1.0), 1.0)
    return FINGER_LENGTH_M * math.sqrt(1.0 - sin_angle * sin_angle)


def approach_height_m(obj: ObjectSpec) -> float:
    """Wrist (palm centre) height so that the pads meet the object near its middle.

    The hinge line sits ``PAD_LEVER_M`` above the object's centre, but high
    enough that the fingertips clear the table by ``TABLE_CLEARANCE_M`` (1 cm)
    when the digits hang straight down. A box or an upright cylinder so low that
    the closing fingertips would meet it less than a pad radius below its top
    (the Box and Blocks Test's 25 mm cube: on its top edges, which squeeze it out
    of the hand as it is carried) is met on its sides: the hand comes down until
    the fingertips meet the side at its middle, or as low as straight digits
    clear the table by ``SMALL_OBJECT_CLEARANCE_M``, as a person lowers their
    hand to pick a small block from a table with the fingertips. No object of
    the library before ``bbt_cube`` is met this way.
    """
    hinge_z = max(obj.half_height_m + PAD_LEVER_M,
                  FINGER_LENGTH_M + THUMB_PAD_RADIUS_M + TABLE_CLEARANCE_M)
    if obj.shape != "sphere":
        depth_m = fingertip_meet_depth_m(obj)
        if hinge_z - depth_m > obj.height_m - FINGER_PAD_RADIUS_M:
            hinge_z = max(obj.half_height_m + depth_m, FINGER_LENGTH_M + THUMB_PAD_RADIUS_M
                          + SMALL_OBJECT_CLEARANCE_M)
    return hinge_z + HINGE_BELOW_PALM_M


def build_spec(obj: ObjectSpec, motor: MotorSpec | None = None,
               timestep_s: float = 0.002, pads: PadSpec | None = None) -> mujoco.MjSpec:
    """Assemble the hand, the table and one object as an ``MjSpec``.

    Parameters
    ----------
    obj : ObjectSpec
        The object, placed centred between the digits, resting on the table.
    motor : MotorSpec, optional
        Drive parameters; default ``MotorSpec()``.
    timestep_s : float
        Physics timestep in seconds (1-2 ms recommended).
    pads : PadSpec, optional
        Fingertip pads; default ``PadSpec()``.

    Raises
    ------
    ValueError
        If the timestep is outside 0.1-5 ms, or too coarse for the pad spring
        (``sqrt(k / m_pad) * timestep_s > 1``).
    """
    motor = motor or MotorSpec()
    pads = pads or PadSpec()
    if not 1e-4 <= timestep_s <= 0.005:
        raise HandSpecError(f"timestep_s: expected 0.0001..0.005 s, found {timestep_s!r}")
    xml = resources.files("sim.hand").joinpath("assets", HAND_XML).read_text()
    spec = mujoco.MjSpec.from_string(xml)
    spec.option.timestep = timestep_s
    _set_pads(spec, pads, timestep_s)

    tau = motor.output_stall_torque_nm
    act = spec.actuator("motor")
    act.gainprm[0] = tau
    act.biasprm[2] = -tau / motor.output_no_load_speed_rad_s
    # Reflected rotor inertia J G^2 on the tendon, spread over the digits in
    # proportion to their coefficient so that the coupled motion sees J G^2 c^T c.
    coef_sum = sum(DRIVE_COEF.values())
    reflected = motor.rotor_inertia_kg_m2 * motor.gear_ratio**2
    for joint, coef in DRIVE_COEF.items():
        spec.joint(joint).armature = reflected * coef_sum * coef

    spec.body("wrist").pos = [0.0, 0.0, approach_height_m(obj)]
    # Centred between the pad surfaces (the thumb pad is 1 mm thicker than the
    # finger pads), so that both sides touch together on a symmetric close.
    _add_object(spec, obj, (GRASP_CENTRE_X_M, 0.0, obj.half_height_m))
    site = mujoco.mjtObj.mjOBJ_SITE
    spec.add_sensor(name="object_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=site,
                    objname="object_center")
    spec.add_sensor(name="object_vel", type=mujoco.mjtSensor.mjSENS_FRAMELINVEL, objtype=site,
                    objname="object_center")
    # Object centre in the palm frame: the slip / drop displacement reading.
    spec.add_sensor(name="object_in_palm", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=site,
                    objname="object_center", reftype=mujoco.mjtObj.mjOBJ_BODY, refname="palm")
    return spec


def _set_pads(spec: mujoco.MjSpec, pads: PadSpec, timestep_s: float) -> None:
    """Write ``pads`` into the pad joints and check each explicit spring is resolved."""
    for name in PAD_JOINTS:
        stiffness = pads.joint_stiffness_n_m(name)
        # Each pad joint carries the pad geom of the same name.
        mass_kg = spec.geom(name).mass
        omega_dt = math.sqrt(stiffness / mass_kg) * timestep_s
        if omega_dt > 1.0:
            raise HandSpecError(
                f"PadSpec.stiffness_n_m: expected sqrt(k / m_pad) * dt <= 1 for a stable pad "
                f"spring, found {omega_dt:.2f} on {name} (k = {stiffness} N/m, m_pad = "
                f"{mass_kg} kg, dt = {timestep_s} s)"
            )
        joint = spec.joint(name)
        # Linear terms only (MuJoCo also takes higher-order polynomial coefficients).
        joint.stiffness = [stiffness, 0.0, 0.0]
        joint.damping = [pads.joint_damping_n_s_m(name), 0.0, 0.0]
        # The upper bound only limits the rebound of an unloaded pad.
        joint.range = [-pads.travel_m, pads.travel_m]


def _add_object(spec: mujoco.MjSpec, obj: ObjectSpec, pos: tuple[float, float, float]) -> None:
    """Add the free ``object`` body (geom ``object``, site ``object_center``)."""
    body = spec.worldbody.add_body(name="object", pos=list(pos))
    body.add_freejoint(name="object")
    geom_type = {
        "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
        "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
        "box": mujoco.mjtGeom.mjGEOM_BOX,
    }[obj.shape]
    size = list(obj.size_m) + [0.0] * (3 - len(obj.size_m))
    body.add_geom(
        name="object", type=geom_type, size=size, mass=obj.mass_kg,
        friction=[obj.friction, 0.005, 0.0001], solref=list(obj.solref),
        solimp=[*obj.solimp, 0.5, 2.0], priority=1, contype=2, conaffinity=3, rgba=list(obj.rgba),
    )
    body.add_site(name="object_center", size=[0.004, 0, 0])


def build_pinch_model(obj: ObjectSpec, grip_force_n: float,
                      timestep_s: float = 0.002) -> mujoco.MjModel:
    """Two flat pads squeezing ``obj`` with exactly ``grip_force_n`` each, no table.

    A reference fixture for Coulomb friction with the hand's contact physics:
    the solver options (cone, impratio, noslip, tolerances) and the pad contact
    parameters are those of ``hand.xml``. Each pad slides along x, pushed
    inward by a force actuator (``ctrl = 1`` gives ``grip_force_n``), so the
    normal force on each side is the commanded force whatever the pose. Pads
    are geoms ``pad_left`` and ``pad_right``; gravity acts along -z.
    """
    hand = mujoco.MjSpec.from_string(
        resources.files("sim.hand").joinpath("assets", HAND_XML).read_text())
    spec = mujoco.MjSpec()
    for name in ("timestep", "integrator", "cone", "impratio", "noslip_iterations",
                 "iterations", "tolerance", "ccd_tolerance"):
        setattr(spec.option, name, getattr(hand.option, name))
    spec.option.timestep = timestep_s
    pad = hand.geom("thumb_pad")
    half_w = obj.width_m / 2
    for side, sign in (("left", 1.0), ("right", -1.0)):
        body = spec.worldbody.add_body(name=f"pad_{side}", pos=[-sign * (half_w + 0.011), 0, 0])
        body.add_joint(name=f"pad_{side}", type=mujoco.mjtJoint.mjJNT_SLIDE,
                       axis=[sign, 0, 0], damping=2.0)
        body.add_geom(name=f"pad_{side}", type=mujoco.mjtGeom.mjGEOM_BOX,
                      size=[0.01, 0.03, 0.03], mass=0.05, friction=list(pad.friction),
                      solref=list(pad.solref), solimp=list(pad.solimp), contype=1,
                      conaffinity=2)
        spec.add_actuator(name=f"pad_{side}", target=f"pad_{side}",
                          trntype=mujoco.mjtTrn.mjTRN_JOINT, gainprm=[grip_force_n] + [0] * 9,
                          ctrlrange=[0, 1])
    _add_object(spec, obj, (0.0, 0.0, 0.0))
    return spec.compile()


def build_model(obj: ObjectSpec, motor: MotorSpec | None = None,
                timestep_s: float = 0.002, pads: PadSpec | None = None) -> mujoco.MjModel:
    """Compile the hand with ``obj``; see :func:`build_spec`."""
    return build_spec(obj, motor, timestep_s, pads).compile()


@dataclass(frozen=True)
class HandIds:
    """Model indices resolved once, so the step loop never looks up names.

    Attributes hold MuJoCo ids (geoms, bodies, actuators) and ``sensordata``
    addresses. ``geom_side`` maps every geom id to 1 (thumb), 2 (index or
    middle) or 0 (anything else). ``pair_side[(g1, g2)]`` is ``(side, sign)`` for
    every digit-object geom pair, with ``sign = +1`` when the object is ``g2``
    (MuJoCo's contact force acts on ``geom2``) and -1 otherwise.
    """

    motor: int
    wrist_act: np.ndarray
    object_body: int
    object_geom: int
    palm_body: int
    object_qpos: int
    object_dof: int
    finger_qpos: int
    thumb_qpos: int
    geom_side: np.ndarray
    pair_side: dict[tuple[int, int], tuple[int, float]]
    sens_finger_pos: int
    sens_finger_vel: int
    sens_motor_force: int
    sens_touch: np.ndarray
    sens_object_pos: int
    sens_object_in_palm: int

    @classmethod
    def from_model(cls, model: mujoco.MjModel) -> HandIds:
        """Resolve the ids of a model made by :func:`build_model`."""

        def gid(name: str) -> int:
            return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)

        def adr(name: str) -> int:
            sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, name)
            return int(model.sensor_adr[sid])

        side = np.zeros(model.ngeom, dtype=np.int8)
        for name in ("thumb_link", "thumb_pad"):
            side[gid(name)] = 1
        for name in ("index_link", "index_pad", "middle_link", "middle_pad"):
            side[gid(name)] = 2
        obj_joint = model.joint("object")
        obj = gid("object")
        obj_body = model.body("object").id
        pair: dict[tuple[int, int], tuple[int, float]] = {}
        for g in np.flatnonzero(side).tolist():
            pair[(g, obj)] = (int(side[g]), 1.0)
            pair[(obj, g)] = (int(side[g]), -1.0)
        return cls(
            motor=model.actuator("motor").id,
            wrist_act=np.array([model.actuator(n).id for n in WRIST_ACTUATORS]),
            object_body=obj_body,
            object_geom=obj,
            palm_body=model.body("palm").id,
            object_qpos=int(obj_joint.qposadr[0]),
            object_dof=int(obj_joint.dofadr[0]),
            finger_qpos=int(model.joint("index").qposadr[0]),
            thumb_qpos=int(model.joint("thumb").qposadr[0]),
            geom_side=side,
            pair_side=pair,
            sens_finger_pos=adr("finger_pos"),
            sens_finger_vel=adr("finger_vel"),
            sens_motor_force=adr("motor_force"),
            sens_touch=np.array([adr(n) for n in ("thumb_touch", "index_touch",
                                                  "middle_touch")]),
            sens_object_pos=adr("object_pos"),
            sens_object_in_palm=adr("object_in_palm"),
        )
