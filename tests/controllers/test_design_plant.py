import numpy as np
import pytest

from controllers import ContactGate, check_plant, design_controller
from controllers.base import observation_from_info
from controllers.design import DEFAULT_SPECS
from controllers.design_plant import design_plant, object_for, object_force_bounds
from sim.hand.grasp_env import GraspEnv, GraspTask

CAN = {"mass_kg": 0.4, "friction": 0.5}


@pytest.fixture(scope="module")
def linearized():
    return design_plant(object_for("can", **CAN))


def test_linearized_plant_is_a_strictly_proper_design_model(linearized):
    p = linearized.model
    assert p.dt == 0.01
    assert np.all(np.asarray(p.D) == 0)
    check_plant(p)
    # the truncated creep modes are slow (> 10 s) and the reduced model still fits the step
    assert min(linearized.fit["removed_time_constants_s"], default=np.inf) > 10.0
    assert linearized.fit["step_fit_percent"] > 95.0
    # truncation removes modes: the full model fits no worse (up to rounding of the fits)
    assert linearized.fit["full_step_fit_percent"] >= linearized.fit["step_fit_percent"] - 0.05


def test_identified_and_linearized_agree_in_the_control_band(linearized):
    ident = design_plant(object_for("can", **CAN), method="identified")
    assert ident.fit["fit_percent"] > 90.0
    w = np.array([5.0, 20.0, 50.0])
    z = np.exp(1j * w * 0.01)
    assert np.abs(ident.model(z)) == pytest.approx(np.abs(linearized.model(z)), rel=0.05)


def test_unknown_method_lists_valid_ones():
    with pytest.raises(LookupError, match=r"\['linearized', 'identified'\]"):
        design_plant("can", method="guess")


def _run(controller, reference_n, episode_s=3.0, delay_samples=1):
    env = GraspEnv({"name": "can", **CAN}, reference_n, task=GraspTask(episode_s=episode_s))
    obs, info = env.reset(seed=0)
    controller.reset()
    pending = [0.0] * delay_samples
    forces = []
    while True:
        u = controller.act(observation_from_info(info, reference_n))
        pending.append(u)
        obs, _, terminated, truncated, info = env.step(
            np.array([pending.pop(0)], dtype=np.float32))
        forces.append(info["grip_force_n"])
        if terminated or truncated:
            break
    env.close()
    return np.array(forces), info


@pytest.mark.parametrize("name", ["pid", "lead_lag", "mpc"])
def test_nonlinear_loop_holds_the_can(linearized, name):
    bounds = object_force_bounds(linearized.object)
    spec = dict(DEFAULT_SPECS[name])
    if name == "mpc":
        spec["force_bounds"] = bounds
    ctl = ContactGate(design_controller(name, linearized.model, **spec))
    forces, info = _run(ctl, 8.0)
    assert info["lifted"] and not info["dropped"]
    assert info["object_height_m"] > 0.1
    # through the lift the grip never falls to the Coulomb threshold m g / (2 mu)
    assert forces[100:].min() > 0.4 * 9.81 / (2 * 0.5)
    assert np.all(np.abs(forces[200:] - 8.0) < 0.5)  # holding, after the lift
    assert forces[-1] == pytest.approx(8.0, abs=0.05)


def test_mpc_keeps_the_fragility_bound_on_the_nonlinear_hand(linearized):
    bounds = object_force_bounds(linearized.object.replace(break_force_n=12.0))
    mpc = design_controller("mpc", linearized.model, force_bounds=bounds)
    forces, info = _run(ContactGate(mpc), 20.0)  # asks for more than the object takes
    assert not info["dropped"]
    settled = forces[100:]
    assert np.all(settled <= bounds.max_n + 0.5)  # soft bound: the overshoot of the hand-over
    assert settled[-1] == pytest.approx(bounds.max_n, abs=0.1)
    assert mpc.stats_.n_failures == 0
