"""First-contact impact: closing at a constant command on fragile and rigid objects.

The hand closes at a constant command ``c`` and holds it (a contact gate whose
controller has not reacted yet). ``peak_force_n`` is the largest thumb- or
finger-side normal sum, at every physics substep, from the first touch until
20 ms (two control periods) after both sides touch.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.hand.contact import FirstContact, first_contact_peak, read_contacts
from sim.hand.grasp_env import GraspEnv, GraspTask, HandSpec
from sim.hand.model import MotorSpec, PadSpec, build_model
from sim.hand.objects import make_object

COMMANDS = (0.1, 0.2, 0.4)
OBJECTS = ("egg", "cup", "can")
SEEDS = (0, 1, 2, 3)
JITTER_M = 0.003


def _close(name: str, command: float, seed: int = 0, hand: HandSpec | None = None
           ) -> FirstContact:
    task = GraspTask(position_jitter_m=JITTER_M if seed else 0.0)
    env = GraspEnv(name, 0.0, hand=hand, task=task)
    env.reset(seed=seed)
    return first_contact_peak(env.model, env.data, env.ids, command)


@pytest.fixture(scope="module")
def peaks() -> dict[tuple[str, float, int], FirstContact]:
    return {(name, c, seed): _close(name, c, seed)
            for name in OBJECTS for c in COMMANDS for seed in SEEDS}


@pytest.mark.parametrize("name", OBJECTS)
@pytest.mark.parametrize("seed", SEEDS)
def test_peak_grows_with_the_closing_command(peaks, name: str, seed: int) -> None:
    values = [peaks[(name, c, seed)].peak_force_n for c in COMMANDS]
    assert all(v > 0 for v in values)
    assert np.all(np.diff(values) > 0), values


def test_gentle_close_on_the_egg_stays_below_3_n_and_does_not_crush_it(peaks) -> None:
    egg = make_object("egg")
    for seed in SEEDS:
        fc = peaks[("egg", 0.1, seed)]
        assert fc.peak_force_n < 3.0
        assert fc.peak_force_n < egg.break_force_n
        assert fc.grasp_time_s >= fc.touch_time_s > 0


@pytest.mark.parametrize("name", OBJECTS)
def test_slow_close_has_no_impact_overshoot(peaks, name: str) -> None:
    # At c = 0.1 the force rises monotonically to the stalled drive's squeeze:
    # no transient above the settled force, which is c times the stall grip
    # within 30 % (the lever arm depends on where the pads touch the object).
    for seed in SEEDS:
        fc = peaks[(name, 0.1, seed)]
        assert fc.overshoot == pytest.approx(1.0, abs=0.02)
        assert fc.settled_force_n == pytest.approx(0.1 * MotorSpec().max_grip_force_n, rel=0.3)


def test_fast_close_keeps_its_real_impact() -> None:
    # Full command: the pads bottom out at speed; the transient is real and
    # must show (on the egg, far above the settled stall force).
    fc = _close("egg", 1.0)
    assert fc.peak_force_n > 50.0
    assert fc.overshoot > 1.1


def test_rigid_pads_and_heavy_rotor_reproduce_the_old_impact() -> None:
    # The mechanism: with (almost) no pad travel and the former 4e-7 kg m^2 rotor,
    # the reflected inertia stops against a stiff contact and the gentle close
    # hits the egg with about ten times the force.
    old = _close("egg", 0.1, hand=HandSpec(motor=MotorSpec(rotor_inertia_kg_m2=4e-7),
                                          pads=PadSpec(travel_m=1e-5)))
    new = _close("egg", 0.1)
    assert old.peak_force_n > 5.0 * new.peak_force_n
    assert old.overshoot > 1.2


def test_same_seed_gives_identical_measurement() -> None:
    a = _close("egg", 0.2, seed=5)
    b = _close("egg", 0.2, seed=5)
    c = _close("egg", 0.2, seed=6)
    assert a == b
    assert a != c


def test_peak_is_the_substep_maximum_of_the_crush_reading() -> None:
    # Independent re-computation: step by hand and take the maximum of
    # max(thumb, finger) over the same window.
    fc = _close("cup", 0.2)
    env = GraspEnv("cup", 0.0)
    env.reset(seed=0)
    m, d, ids = env.model, env.data, env.ids
    d.ctrl[ids.motor] = 0.2
    forces, times = [], []
    while d.time < fc.grasp_time_s + fc.window_s - 0.5 * m.opt.timestep:
        mujoco.mj_step(m, d)
        r = read_contacts(m, d, ids)
        forces.append(max(r.grip_force_n, r.finger_force_n))
        times.append(d.time)
    assert max(forces) == fc.peak_force_n
    assert times[int(np.flatnonzero(np.array(forces) > 0)[0])] == fc.touch_time_s


def test_measurement_arguments_are_validated() -> None:
    model = build_model(make_object("egg"))
    data = mujoco.MjData(model)
    from sim.hand.model import HandIds

    ids = HandIds.from_model(model)
    with pytest.raises(ValueError, match="closing_command"):
        first_contact_peak(model, data, ids, 0.0)
    with pytest.raises(ValueError, match="window_s"):
        first_contact_peak(model, data, ids, 0.1, window_s=0.5, hold_s=0.1)


def test_no_grasp_within_the_time_limit_raises() -> None:
    env = GraspEnv("egg", 0.0)
    env.reset(seed=0)
    d, ids = env.data, env.ids
    d.qpos[ids.object_qpos:ids.object_qpos + 2] = (0.3, 0.3)  # out of reach
    with pytest.raises(RuntimeError, match="no two-sided contact"):
        first_contact_peak(env.model, d, ids, 0.2, max_close_s=0.5)
