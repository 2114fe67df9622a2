"""The MuJoCo prosthetic hand: motor model, model assembly with an object, ids.

The hand (``sim/assets/hand.xml``) is a single-drive myoelectric hand: one DC
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
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources

import mujoco
import numpy as np

from sim.objects import ObjectSpec

HAND_XML = "hand.xml"
DIGIT_JOINTS = ("thumb", "index", "middle")
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
        Rotor inertia; reflected to the digits as joint armature ``J G^2``.

    Notes
    -----
    Defaults: 0.04 N m stall, 1480 rad/s no load (7.4 V with k_t = 5 mN m/A,
    i.e. an 8 A stall current from a 2-cell Li-ion pack), 250:1 gearbox at 85 %:
    8.5 N m stall at the tendon, i.e. about 106 N on an 80 mm thumb lever, and a
    free tendon speed of 5.9 rad/s: the digits sweep 1.65 rad in about 0.6 s.
    """

    stall_torque_nm: float = 0.04
    no_load_speed_rad_s: float = 1480.0
    gear_ratio: float = 250.0
    efficiency: float = 0.85
    torque_constant_nm_a: float = 0.005
    rotor_inertia_kg_m2: float = 4e-7

    def __post_init__(self) -> None:
        for name in ("stall_torque_nm", "no_load_speed_rad_s", "gear_ratio",
                     "torque_constant_nm_a", "rotor_inertia_kg_m2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"MotorSpec.{name}: expected a positive number, found {value!r}")
        if not 0 < self.efficiency <= 1:
            raise ValueError(
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


def approach_height_m(obj: ObjectSpec) -> float:
    """Wrist (palm centre) height so that the pads meet the object near its middle.

    The hinge line sits ``PAD_LEVER_M`` above the object's centre, but high
    enough that the fingertips clear the table by 1 cm when the digits hang
    straight down.
    """
    hinge_z = max(obj.half_height_m + PAD_LEVER_M, FINGER_LENGTH_M + 0.011 + 0.01)
    return hinge_z + HINGE_BELOW_PALM_M


def build_spec(obj: ObjectSpec, motor: MotorSpec | None = None,
               timestep_s: float = 0.002) -> mujoco.MjSpec:
    """Assemble the hand, the table and one object as an ``MjSpec``.

    Parameters
    ----------
    obj : ObjectSpec
        The object, placed centred between the digits, resting on the table.
    motor : MotorSpec, optional
        Drive parameters; default ``MotorSpec()``.
    timestep_s : float
        Physics timestep in seconds (1-2 ms recommended).
    """
    motor = motor or MotorSpec()
    if not 1e-4 <= timestep_s <= 0.005:
        raise ValueError(f"timestep_s: expected 0.0001..0.005 s, found {timestep_s!r}")
    xml = resources.files("sim").joinpath("assets", HAND_XML).read_text()
    spec = mujoco.MjSpec.from_string(xml)
    spec.option.timestep = timestep_s

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
    _add_object(spec, obj, (0.0, 0.0, obj.half_height_m))
    site = mujoco.mjtObj.mjOBJ_SITE
    spec.add_sensor(name="object_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=site,
                    objname="object_center")
    spec.add_sensor(name="object_vel", type=mujoco.mjtSensor.mjSENS_FRAMELINVEL, objtype=site,
                    objname="object_center")
    # Object centre in the palm frame: the slip / drop displacement reading.
    spec.add_sensor(name="object_in_palm", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=site,
                    objname="object_center", reftype=mujoco.mjtObj.mjOBJ_BODY, refname="palm")
    return spec


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
    the solver options (cone, impratio, noslip, tolerance) and the pad contact
    parameters are those of ``hand.xml``. Each pad slides along x, pushed
    inward by a force actuator (``ctrl = 1`` gives ``grip_force_n``), so the
    normal force on each side is the commanded force whatever the pose. Pads
    are geoms ``pad_left`` and ``pad_right``; gravity acts along -z.
    """
    hand = mujoco.MjSpec.from_string(
        resources.files("sim").joinpath("assets", HAND_XML).read_text())
    spec = mujoco.MjSpec()
    for name in ("timestep", "integrator", "cone", "impratio", "noslip_iterations",
                 "iterations", "tolerance"):
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
                timestep_s: float = 0.002) -> mujoco.MjModel:
    """Compile the hand with ``obj``; see :func:`build_spec`."""
    return build_spec(obj, motor, timestep_s).compile()


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
