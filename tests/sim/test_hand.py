"""The hand model: drive parameters, closing speed, grip force, encoders and current."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.hand.contact import read_contacts
from sim.hand.model import PAD_JOINTS, HandIds, MotorSpec, PadSpec, build_model
from sim.hand.objects import make_object


def test_motor_spec_closed_forms() -> None:
    motor = MotorSpec()
    assert motor.stall_current_a == pytest.approx(0.04 / 0.005)
    assert motor.supply_voltage_v == pytest.approx(7.4)
    assert motor.output_stall_torque_nm == pytest.approx(0.04 * 250 * 0.85)
    assert motor.output_no_load_speed_rad_s == pytest.approx(1480 / 250)
    assert motor.current_a(motor.output_stall_torque_nm) == pytest.approx(motor.stall_current_a)
    with pytest.raises(ValueError, match="efficiency"):
        MotorSpec(efficiency=1.5)


def test_actuator_gains_come_from_motor_spec() -> None:
    motor = MotorSpec(stall_torque_nm=0.02, gear_ratio=300)
    model = build_model(make_object("can"), motor)
    act = model.actuator("motor")
    assert act.gainprm[0] == pytest.approx(motor.output_stall_torque_nm)
    assert act.biasprm[2] == pytest.approx(-motor.output_stall_torque_nm
                                           / motor.output_no_load_speed_rad_s)
    reflected = motor.rotor_inertia_kg_m2 * motor.gear_ratio**2
    assert model.joint("thumb").armature[0] == pytest.approx(2 * reflected)
    assert model.joint("index").armature[0] == pytest.approx(reflected)


def _free_model() -> tuple[mujoco.MjModel, mujoco.MjData, HandIds]:
    model = build_model(make_object("can"))
    data = mujoco.MjData(model)
    ids = HandIds.from_model(model)
    data.qpos[ids.object_qpos:ids.object_qpos + 3] = (0.3, 0.3, 0.061)  # out of reach
    for joint in ("thumb", "index", "middle"):
        data.qpos[model.joint(joint).qposadr[0]] = model.joint(joint).range[0]
    return model, data, ids


def test_free_full_close_takes_0p4_to_1_s_and_current_follows_dc_motor_law() -> None:
    model, data, ids = _free_model()
    motor = MotorSpec()
    data.ctrl[ids.motor] = 1.0
    q_closed = model.joint("index").range[1] - 0.01
    close_time = None
    current_mid = None
    while data.time < 2.0:
        mujoco.mj_step(model, data)
        q = data.qpos[ids.finger_qpos]
        if current_mid is None and q > 0.5:
            force = data.sensordata[ids.sens_motor_force]
            current_mid = motor.current_a(force)
            v = data.actuator_velocity[ids.motor]
            expected = motor.stall_current_a * (1.0 - v / motor.output_no_load_speed_rad_s)
            assert current_mid == pytest.approx(expected, rel=1e-9)
        if q >= q_closed:
            close_time = data.time
            break
    assert close_time is not None and 0.4 <= close_time <= 1.0
    # Mid-stroke the motor runs near no-load: little current.
    assert 0 < current_mid < 0.2 * motor.stall_current_a
    # The coupling keeps the three digits together.
    for joint in ("thumb", "middle"):
        assert data.qpos[model.joint(joint).qposadr[0]] == pytest.approx(
            data.qpos[ids.finger_qpos], abs=0.01)


def test_stall_grip_force_near_100_n_and_stall_current() -> None:
    model = build_model(make_object("block"))
    data = mujoco.MjData(model)
    ids = HandIds.from_model(model)
    data.ctrl[ids.motor] = 1.0
    mujoco.mj_step(model, data, 1000)
    reading = read_contacts(model, data, ids)
    assert 70 <= reading.grip_force_n <= 130
    # Horizontal contact normals on a box: both sides carry the same force.
    assert reading.finger_force_n == pytest.approx(reading.grip_force_n, rel=0.02)
    motor = MotorSpec()
    current = motor.current_a(data.sensordata[ids.sens_motor_force])
    assert current == pytest.approx(motor.stall_current_a, rel=0.01)
    # The thumb touch sensor encloses the pad and reads the same normal force.
    thumb_touch = data.sensordata[ids.sens_touch[0]]
    assert thumb_touch == pytest.approx(reading.grip_force_n, rel=0.01)
    # Encoders: jointpos / jointvel sensors read the index joint (sensors are
    # evaluated before the last integration, hence the tolerance).
    assert data.sensordata[ids.sens_finger_pos] == pytest.approx(data.qpos[ids.finger_qpos],
                                                                 abs=1e-6)
    assert abs(data.sensordata[ids.sens_finger_vel]) < 1e-3


@pytest.mark.parametrize("command", [0.2, 0.4])
def test_grip_force_is_proportional_to_command_at_stall(command: float) -> None:
    # Above ~15 N; at lower grips the table's friction on the resting object
    # carries part of the thumb/finger imbalance and the ratio drifts.
    grips = []
    for u in (command, 2 * command):
        model = build_model(make_object("block"))
        data = mujoco.MjData(model)
        ids = HandIds.from_model(model)
        data.ctrl[ids.motor] = u
        mujoco.mj_step(model, data, 1500)
        grips.append(read_contacts(model, data, ids).grip_force_n)
    assert grips[1] / grips[0] == pytest.approx(2.0, rel=0.05)


def test_timestep_is_validated() -> None:
    with pytest.raises(ValueError, match="timestep_s"):
        build_model(make_object("can"), timestep_s=0.02)


def test_pad_spec_is_written_into_the_pad_joints() -> None:
    pads = PadSpec(stiffness_n_m=800.0, damping_n_s_m=2.5, travel_m=0.0025)
    # The thumb pad opposes both fingers: twice a finger pad's stiffness, so a side
    # of the grasp bottoms out at 2 k travel.
    assert PadSpec.thumb_scale == 2.0
    assert pads.bottom_out_force_n == pytest.approx(2 * 800.0 * 0.0025)
    model = build_model(make_object("egg"), pads=pads)
    for name in PAD_JOINTS:
        joint = model.joint(name)
        scale = 2.0 if name == "thumb_pad" else 1.0
        assert joint.stiffness[0] == scale * 800.0
        assert model.dof_damping[joint.dofadr[0]] == scale * 2.5
        assert tuple(joint.range) == (-0.0025, 0.0025)
        assert model.dof_armature[joint.dofadr[0]] == 0.0
    with pytest.raises(LookupError, match="pad joint"):
        pads.joint_stiffness_n_m("index")


def test_pad_spring_at_rest_and_under_a_light_squeeze() -> None:
    # Open hand: the pads rest at zero compression. A light squeeze of the block
    # (thumb force below the bottom-out force) compresses the thumb pad by
    # F_axial / k_thumb, where F_axial is the contact force along the pad's slide axis.
    model = build_model(make_object("block"))
    data = mujoco.MjData(model)
    ids = HandIds.from_model(model)
    mujoco.mj_forward(model, data)
    adr = model.joint("thumb_pad").qposadr[0]
    assert data.qpos[adr] == 0.0
    data.ctrl[ids.motor] = 0.2  # close, then relax to a light squeeze
    mujoco.mj_step(model, data, 300)
    data.ctrl[ids.motor] = 0.02
    mujoco.mj_step(model, data, 500)
    reading = read_contacts(model, data, ids)
    pads = PadSpec()
    assert 0.5 < reading.grip_force_n < pads.bottom_out_force_n
    axis = data.xaxis[model.joint("thumb_pad").id]
    body = model.joint("thumb_pad").bodyid[0]
    force_on_pad = np.zeros(6)
    axial = 0.0
    for i in range(data.ncon):
        g1, g2 = data.contact.geom[i]
        if {g1, g2} == {model.geom("thumb_pad").id, ids.object_geom}:
            mujoco.mj_contactForce(model, data, i, force_on_pad)
            # Contact force acts on geom2 (the object): the pad receives minus it.
            world = data.contact.frame[i].reshape(3, 3).T @ force_on_pad[:3]
            sign = -1.0 if g2 == ids.object_geom else 1.0
            axial += sign * world @ axis
    assert model.geom_bodyid[model.geom("thumb_pad").id] == body
    compression_m = -data.qpos[adr]
    assert compression_m == pytest.approx(-axial / pads.joint_stiffness_n_m("thumb_pad"),
                                          rel=0.02)


@pytest.mark.parametrize("field, value", [("stiffness_n_m", 0.0), ("damping_n_s_m", -1.0),
                                          ("travel_m", 0.02)])
def test_pad_spec_is_validated(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        PadSpec(**{field: value})


def test_too_stiff_pad_for_the_timestep_is_refused() -> None:
    # thumb pad: omega dt = sqrt(2 * 20000 N/m / 0.02 kg) * 0.002 s = 2.83 > 1
    with pytest.raises(ValueError, match=r"found 2\.83 on thumb_pad"):
        build_model(make_object("egg"), pads=PadSpec(stiffness_n_m=20000.0))
    build_model(make_object("egg"), pads=PadSpec(stiffness_n_m=20000.0), timestep_s=0.0005)
