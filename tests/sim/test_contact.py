"""Contact measurement against independent re-computations, and outcome tracking."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.hand.contact import ContactReading, OutcomeTracker, read_contacts
from sim.hand.model import HandIds, build_model
from sim.hand.objects import make_object


def _squeezing(name: str, command: float, lift_m: float = 0.0, steps: int = 600):
    model = build_model(make_object(name))
    data = mujoco.MjData(model)
    ids = HandIds.from_model(model)
    data.ctrl[ids.motor] = command
    mujoco.mj_step(model, data, steps)
    if lift_m:
        wz = model.actuator("wrist_z").id
        for i in range(300):
            data.ctrl[wz] = lift_m * min(1.0, i / 250)
            mujoco.mj_step(model, data)
    return model, data, ids


def contact_force_reference(model: mujoco.MjModel, data: mujoco.MjData,
                            ids: HandIds) -> tuple[float, float]:
    """Thumb- and finger-side normal sums via ``mj_contactForce``, contact by contact.

    A slow, independent re-computation of :func:`read_contacts`, valid for any
    cone type.
    """
    thumb = finger = 0.0
    wrench = np.zeros(6)
    for i in range(data.ncon):
        g1, g2 = data.contact.geom[i]
        if ids.object_geom not in (g1, g2):
            continue
        side = ids.geom_side[g1 if g2 == ids.object_geom else g2]
        if side == 0:
            continue
        mujoco.mj_contactForce(model, data, i, wrench)
        if side == 1:
            thumb += wrench[0]
        else:
            finger += wrench[0]
    return thumb, finger


def _slip_by_body_velocities(model, data, ids) -> float:
    """Tangential relative speed at the hand-object contacts from cvel (numpy)."""
    best = 0.0
    for i in range(data.ncon):
        g1, g2 = data.contact.geom[i]
        other = g1 if g2 == ids.object_geom else g2
        if ids.object_geom not in (g1, g2) or ids.geom_side[other] == 0:
            continue
        p = data.contact.pos[i]
        normal = data.contact.frame[i, :3]
        v = []
        for g in (g1, g2):
            b = model.geom_bodyid[g]
            w, lin = data.cvel[b, :3], data.cvel[b, 3:]
            v.append(lin + np.cross(w, p - data.subtree_com[model.body_rootid[b]]))
        rel = v[1] - v[0]
        tangential = rel - rel.dot(normal) * normal
        best = max(best, float(np.linalg.norm(tangential)))
    return best


@pytest.mark.parametrize("name, command", [("ball", 0.3), ("can", 0.6), ("cup", 1.0),
                                           ("egg", 0.2)])
def test_forces_match_mj_contact_force(name: str, command: float) -> None:
    model, data, ids = _squeezing(name, command)
    reading = read_contacts(model, data, ids)
    thumb, finger = contact_force_reference(model, data, ids)
    assert reading.grip_force_n > 1.0
    assert reading.grip_force_n == pytest.approx(thumb, rel=1e-12)
    assert reading.finger_force_n == pytest.approx(finger, rel=1e-12)
    assert reading.thumb_contact and reading.finger_contact


@pytest.mark.parametrize("name", ["ball", "can", "cup"])
def test_slip_speed_matches_body_velocity_recomputation(name: str) -> None:
    model, data, ids = _squeezing(name, 0.4, steps=150)  # still closing: nonzero motion
    reading = read_contacts(model, data, ids)
    assert reading.slip_speed_m_s > 1e-5
    assert reading.slip_speed_m_s == pytest.approx(_slip_by_body_velocities(model, data, ids),
                                                   rel=1e-6, abs=1e-9)


def test_load_force_is_the_weight_when_lifted() -> None:
    model, data, ids = _squeezing("can", 0.3, lift_m=0.05)
    mujoco.mj_step(model, data, 300)
    reading = read_contacts(model, data, ids)
    assert reading.load_force_n == pytest.approx(0.386 * 9.81, rel=0.01)


def test_no_contact_reads_zero() -> None:
    model = build_model(make_object("can"))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    reading = read_contacts(model, data, HandIds.from_model(model))
    assert reading == ContactReading()


def _reading(slip: float, n: int = 2, grip: float = 5.0) -> ContactReading:
    return ContactReading(grip_force_n=grip, finger_force_n=grip, slip_speed_m_s=slip,
                          n_contacts=n, thumb_contact=n > 0, finger_contact=n > 0)


def test_slip_event_counts_once_per_crossing_with_hysteresis() -> None:
    tr = OutcomeTracker(slip_threshold_m_s=0.01)
    speeds = [0.0, 0.02, 0.03, 0.008, 0.02, 0.004, 0.02, 0.0]
    for s in speeds:
        tr.update(_reading(s), (0.0, 0.0, 0.0))
    # Crossings at 0.02 (index 1) and after dropping below 0.005 (index 6);
    # 0.008 is above the release level, so index 4 is the same event.
    assert tr.slip_events == 2


def test_slip_distance_is_path_length_in_palm_frame_while_touching() -> None:
    tr = OutcomeTracker()
    tr.reset((0.0, 0.0, -0.05))
    path = [(0.0, 0.0, -0.051), (0.0, 0.0, -0.053), (0.0, 0.003, -0.053)]
    for p in path:
        tr.update(_reading(0.0), p)
    tr.update(_reading(0.0, n=0), (0.0, 0.003, -0.063))  # not touching: not slip
    assert tr.slip_distance_m == pytest.approx(0.001 + 0.002 + 0.003)
    assert not tr.dropped  # 13.3 mm < 30 mm


def test_drop_needs_no_contact_and_distance() -> None:
    tr = OutcomeTracker(drop_distance_m=0.03)
    tr.reset((0.0, 0.0, -0.05))
    tr.update(_reading(0.0, n=2), (0.0, 0.0, -0.09))
    assert not tr.dropped  # still touched
    tr.update(_reading(0.0, n=0), (0.0, 0.0, -0.07))
    assert not tr.dropped  # 20 mm away only
    tr.update(_reading(0.0, n=0), (0.0, 0.0, -0.0801))
    assert tr.dropped


def test_crush_above_break_force_on_either_side() -> None:
    tr = OutcomeTracker(break_force_n=5.0)
    tr.update(_reading(0.0, grip=4.9), (0.0, 0.0, 0.0))
    assert not tr.crushed
    r = _reading(0.0, grip=4.0)
    r.finger_force_n = 5.2
    tr.update(r, (0.0, 0.0, 0.0))
    assert tr.crushed


def test_tracker_validates_thresholds() -> None:
    with pytest.raises(ValueError, match="slip_threshold_m_s"):
        OutcomeTracker(slip_threshold_m_s=0.0)
