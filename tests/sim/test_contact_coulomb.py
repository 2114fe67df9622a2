"""Coulomb friction of the grasp: hold above m g / (2 mu), slip below it.

1. Reference pinch (``build_pinch_model``): two flat pads with the hand's
   contact physics press a free object with exactly F each. The weight is
   carried by friction on both sides, so the object stays iff 2 mu F >= m g.
2. The hand: a box (vertical faces, horizontal contact normals) held in the
   air at 1.2 times the threshold stays put; lowering the command by a third
   drops it.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.hand.grasp_env import GraspEnv, GraspTask, WristSchedule
from sim.hand.model import build_pinch_model
from sim.hand.objects import make_object

G = 9.81
PINCH_OBJECTS = {
    "box_0.2kg_mu1": make_object("block", mass_kg=0.2, friction=1.0),
    "block": make_object("block"),
    "can": make_object("can"),
    "soft_ball": make_object("ball", mass_kg=0.2, friction=0.8),
}


def _pinch(obj, factor):
    threshold_n = obj.mass_kg * G / (2 * obj.friction)
    model = build_pinch_model(obj, factor * threshold_n)
    data = mujoco.MjData(model)
    data.ctrl[:] = 1.0
    gravity = model.opt.gravity.copy()
    model.opt.gravity[:] = 0.0
    mujoco.mj_step(model, data, 100)  # pads close on the object
    model.opt.gravity[:] = gravity
    z_adr = model.joint("object").qposadr[0] + 2
    z0 = data.qpos[z_adr]
    mujoco.mj_step(model, data, 50)
    left = model.geom("pad_left").id
    wrench = np.zeros(6)
    normal_n = 0.0
    for i in range(data.ncon):
        if left in data.contact.geom[i]:
            mujoco.mj_contactForce(model, data, i, wrench)
            normal_n += wrench[0]
    mujoco.mj_step(model, data, 450)  # 1 s in total
    return threshold_n, normal_n, z0 - data.qpos[z_adr]


@pytest.mark.parametrize("name", sorted(PINCH_OBJECTS))
def test_pinch_holds_20_percent_above_threshold(name: str) -> None:
    threshold_n, normal_n, fall_m = _pinch(PINCH_OBJECTS[name], 1.2)
    assert normal_n == pytest.approx(1.2 * threshold_n, rel=1e-3)
    assert abs(fall_m) < 1e-5  # < 10 um of creep in 1 s


@pytest.mark.parametrize("name", sorted(PINCH_OBJECTS))
def test_pinch_slips_20_percent_below_threshold(name: str) -> None:
    _, _, fall_m = _pinch(PINCH_OBJECTS[name], 0.8)
    # Net downward acceleration 0.2 g while in contact: > 9 cm after 1 s.
    assert fall_m > 0.09


def _held_env(obj):
    env = GraspEnv(obj, 0.0, wrist=WristSchedule(lift_after_s=np.inf),
                   task=GraspTask(episode_s=100.0))
    env.reset(seed=0)
    threshold_n = obj.mass_kg * G / (2 * obj.friction)
    u_hold = env.steady_grasp(1.2 * threshold_n, lifted=True)
    return env, threshold_n, u_hold


def _hold(env, command, seconds=1.0):
    infos = []
    for _ in range(int(round(seconds / env.control_dt_s))):
        _, _, terminated, _, info = env.step(np.array([command], dtype=np.float32))
        infos.append(info)
        if terminated:
            break
    return infos


HAND_OBJECTS = [make_object("block", mass_kg=0.2, friction=1.0), make_object("block")]


@pytest.mark.parametrize("obj", HAND_OBJECTS, ids=["0.2kg_mu1", "0.461kg_mu0.6"])
def test_hand_holds_20_percent_above_threshold(obj) -> None:
    env, threshold_n, u_hold = _held_env(obj)
    z0 = env.data.xpos[env.ids.object_body][2]
    infos = _hold(env, u_hold)
    assert len(infos) == 100 and not infos[-1]["dropped"]
    grip = np.array([i["grip_force_n"] for i in infos])
    assert grip.mean() == pytest.approx(1.2 * threshold_n, rel=0.02)
    # Negligible slip: < 0.2 mm of creep in 1 s, no slip event.
    assert abs(infos[-1]["object_height_m"] - z0) < 2e-4
    assert infos[-1]["slip_events"] == 0
    # The load carried by friction equals the weight.
    assert infos[-1]["load_force_n"] == pytest.approx(obj.mass_kg * G, rel=0.02)
    assert infos[-1]["grip_load_ratio"] == pytest.approx(1.2 / (2 * obj.friction), rel=0.03)


@pytest.mark.parametrize("obj", HAND_OBJECTS, ids=["0.2kg_mu1", "0.461kg_mu0.6"])
def test_hand_drops_when_command_lowered_by_a_third(obj) -> None:
    env, _, u_hold = _held_env(obj)
    infos = _hold(env, u_hold * 0.8 / 1.2)
    assert infos[-1]["dropped"], "the object should slide out of the hand"
    assert len(infos) < 100
    assert infos[-1]["slip_events"] >= 1
    assert infos[-1]["slip_distance_m"] > 0.005
