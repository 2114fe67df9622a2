"""The hand's transmission: a self-locking drive holds what it grips and still moves at speed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.hand.drive import (
    BACKDRIVABLE,
    SELF_LOCKING,
    DriveSpec,
    DriveSpecError,
    UnknownDriveError,
    drive_names,
    make_drive,
    motor_for,
)
from sim.hand.grasp_env import GraspEnv, GraspTask, HandSpec, WristSchedule
from sim.hand.model import MotorSpec

FULLY_OPEN_RAD, FULLY_CLOSED_RAD = -0.35, 1.3


def test_the_worm_stage_efficiencies_are_the_inclined_planes() -> None:
    lam, phi = math.radians(4.0), math.atan(0.10)
    assert SELF_LOCKING.worm_forward_efficiency == pytest.approx(math.tan(lam)
                                                                 / math.tan(lam + phi))
    assert SELF_LOCKING.worm_forward_efficiency == pytest.approx(0.409, abs=1e-3)
    assert SELF_LOCKING.worm_reverse_efficiency == pytest.approx(-0.427, abs=1e-3)
    assert SELF_LOCKING.friction_angle_deg == pytest.approx(5.71, abs=0.01)
    assert BACKDRIVABLE.worm_forward_efficiency == BACKDRIVABLE.worm_reverse_efficiency == 1.0
    with pytest.raises(DriveSpecError, match="lead angle below the friction angle"):
        DriveSpec("steep", self_locking=True, lead_angle_deg=10.0, friction_coef=0.10)


def test_the_self_locking_motor_keeps_the_rated_grip_and_speed() -> None:
    motor = MotorSpec()
    sized = motor_for(SELF_LOCKING, motor)
    assert sized.output_stall_torque_nm == pytest.approx(motor.output_stall_torque_nm)
    assert sized.output_no_load_speed_rad_s == motor.output_no_load_speed_rad_s
    assert sized.efficiency == pytest.approx(0.85 * 0.409, abs=1e-3)
    assert sized.stall_current_a > 2 * motor.stall_current_a  # the worm's losses, in current
    assert motor_for(BACKDRIVABLE, motor) is motor


def test_unknown_drives_are_refused_listing_the_known_ones() -> None:
    assert drive_names() == ("backdrivable", "self_locking")
    with pytest.raises(UnknownDriveError, match="backdrivable, self_locking"):
        make_drive("worm")


def _env(drive: str, lift_after_s: float = np.inf) -> GraspEnv:
    env = GraspEnv("can", 0.0, wrist=WristSchedule(lift_after_s=lift_after_s),
                   hand=HandSpec(drive=drive), task=GraspTask(episode_s=60.0))
    env.reset(seed=0)
    return env


def _run(env: GraspEnv, command: float, seconds: float) -> np.ndarray:
    """``(time, finger angle, grip)`` after each control step of ``command``."""
    action = np.array([command], dtype=np.float32)
    out = []
    for _ in range(int(round(seconds / env.control_dt_s))):
        info = env.step(action)[4]
        out.append((info["time_s"], info["finger_position_rad"], info["grip_force_n"]))
    return np.array(out)


@pytest.mark.parametrize("drive", ["self_locking", "backdrivable"])
def test_a_held_can_stays_held_ten_seconds_with_no_command_only_if_self_locking(drive) -> None:
    env = _env(drive, lift_after_s=1.0)
    _run(env, 0.3, 2.0)  # close, lift at 1 s once the grip is established
    env.set_object_load(2.0)  # and something pulls on it: the object may not push open
    grip_before = env.last_info["grip_force_n"]
    held = _run(env, 0.0, 10.0)
    info = env.last_info
    if drive == "self_locking":
        assert not info["dropped"] and info["object_height_m"] > 0.1
        assert np.all(np.abs(held[:, 2] - grip_before) <= 0.05 * grip_before)
        assert np.ptp(held[:, 1]) < 1e-3  # the digits stay where they are
    else:  # the object pushes the backdrivable digits open and falls
        assert info["dropped"] and held[-1, 2] < 0.05 * grip_before


def test_from_a_hold_the_motor_opens_and_closes_the_hand_within_a_second() -> None:
    env = _env("self_locking")
    _run(env, 0.3, 2.0)
    _run(env, 0.0, 1.0)  # held, locked
    opening = _run(env, -1.0, 1.0)
    assert opening[-1, 1] <= FULLY_OPEN_RAD + 0.02
    # the can taken out of the hand: the empty hand closes
    env.data.qpos[env.ids.object_qpos] += 0.4
    closing = _run(env, 1.0, 1.0)
    assert closing[-1, 1] >= FULLY_CLOSED_RAD - 0.02
    for run, end in ((opening, FULLY_OPEN_RAD), (closing, FULLY_CLOSED_RAD)):
        reached = run[np.flatnonzero(np.abs(run[:, 1] - end) <= 0.02)[0], 0] - run[0, 0]
        assert reached <= 1.0


def test_closing_does_not_reopen_when_the_command_falls() -> None:
    """A self-locking grip only rises with the motor's torque; less torque keeps it."""
    env = _env("self_locking")
    _run(env, 0.6, 1.5)
    strong = env.last_info["grip_force_n"]
    weak = _run(env, 0.1, 1.0)
    assert np.all(weak[:, 2] >= 0.95 * strong)
    back = _env("backdrivable")
    _run(back, 0.6, 1.5)
    strong_back = back.last_info["grip_force_n"]
    assert _run(back, 0.1, 1.0)[-1, 2] < 0.5 * strong_back  # the backdrivable grip follows


def test_a_small_opening_command_opens_no_faster_than_the_motor_turns_the_worm() -> None:
    """The object's push does not drive a worm: under an opening command the digits open
    at most at the motor's no-load speed for that command (the coupled digit angle moves
    1/2 of the tendon's 5.9 rad/s at full command), while the backdrivable hand's digits
    are pushed open by the squeezed pads."""
    from sim.hand.model import DRIVE_COEF

    command, seconds = -0.05, 0.3
    speed = MotorSpec().output_no_load_speed_rad_s / sum(DRIVE_COEF.values())
    opened = {}
    for drive in ("self_locking", "backdrivable"):
        env = _env(drive)
        _run(env, 0.3, 2.0)
        _run(env, 0.0 if drive == "self_locking" else 0.3, 0.5)
        before = env.last_info["finger_position_rad"]
        run = _run(env, command, seconds)
        opened[drive] = before - run[:, 1].min()
        assert opened[drive] >= 0.0
    assert opened["self_locking"] <= abs(command) * speed * seconds + 1e-3
    assert opened["backdrivable"] > 1.2 * opened["self_locking"]
