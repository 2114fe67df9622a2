"""GraspEnv: Gymnasium conformance, determinism, references, outcomes, failures."""

from __future__ import annotations

import os
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim  # noqa: E402, F401  (registers the environment)
from sim.hand.grasp_env import GraspEnv, GraspTask, HandSpec, WristSchedule
from sim.recording import Recording
from sim.references import ReferenceSignalError, StreamReference


def _p_controller(obs: np.ndarray, gain: float = 0.008, bias: float = 0.12) -> np.ndarray:
    return np.array([np.clip(bias + gain * (obs[0] - obs[1]), -1, 1)], dtype=np.float32)


def _run(env: GraspEnv, seed: int, n: int = 150) -> np.ndarray:
    obs, _ = env.reset(seed=seed)
    rows = []
    for _ in range(n):
        obs, reward, terminated, truncated, info = env.step(_p_controller(obs))
        rows.append([*obs, reward, info["object_height_m"]])
        if terminated or truncated:
            break
    return np.array(rows)


def _gl_available() -> bool:
    # GLFW without a display aborts the process instead of raising: only try
    # the headless backends or a real display.
    if os.environ.get("MUJOCO_GL") not in ("egl", "osmesa") and not os.environ.get("DISPLAY"):
        return False
    try:
        import mujoco

        renderer = mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8)
        renderer.close()
        return True
    except Exception:  # any GL backend failure means no rendering here
        return False


@pytest.mark.skipif(not _gl_available(), reason="no OpenGL backend (MUJOCO_GL=egl) here")
def test_check_env_passes_without_warnings() -> None:
    # Through gym.make so that the env has a spec: check_env then also builds
    # an rgb_array instance and checks its rendering.
    env = gym.make("griploop/GraspLift-v0", object="can", reference=15.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


def test_check_env_without_rendering() -> None:
    env = GraspEnv("ball", 10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env, skip_render_check=True)
    env.close()


@pytest.mark.skipif(not _gl_available(), reason="no OpenGL backend (MUJOCO_GL=egl) here")
def test_render_frame_content_and_close() -> None:
    env = GraspEnv("can", 15.0, render_mode="rgb_array", render_size=(120, 160))
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (120, 160, 3) and frame.dtype == np.uint8
    assert frame.std() > 5  # a scene, not a blank image
    env.close()
    assert env._renderer is None


def test_registered_id_makes_the_env() -> None:
    env = gym.make("griploop/GraspLift-v0", object="egg", reference=2.0)
    assert isinstance(env.unwrapped, GraspEnv)
    assert env.unwrapped.object_spec.name == "egg"
    env.close()


def test_spaces_and_observation_names() -> None:
    env = GraspEnv()
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    assert env.observation_space.shape == (len(GraspEnv.OBS_NAMES),)
    assert GraspEnv.OBS_NAMES[1] == "grip_force_n"
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.float32 and obs[1] == 0.0
    assert set(info["reward_terms"]) == {"tracking", "slip", "drop", "crush"}


def test_same_seed_same_trajectory_different_seed_differs() -> None:
    jitter = GraspTask(position_jitter_m=0.004)
    a = _run(GraspEnv("ball", 10.0, task=jitter), seed=7)
    b = _run(GraspEnv("ball", 10.0, task=jitter), seed=7)
    c = _run(GraspEnv("ball", 10.0, task=jitter), seed=8)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_grasp_lift_hold_tracks_reference_and_lifts() -> None:
    env = GraspEnv("can", 15.0, task=GraspTask(episode_s=2.5))
    obs, _ = env.reset(seed=0)
    infos = []
    terminated = truncated = False
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(_p_controller(obs, 0.008, 0.17))
        infos.append(info)
    assert truncated and not terminated and len(infos) == 250
    last = infos[-1]
    assert last["lifted"] and last["object_height_m"] > 0.061 + 0.07
    assert last["grip_force_n"] == pytest.approx(15.0, abs=2.0)
    assert last["load_force_n"] == pytest.approx(0.386 * 9.81, rel=0.05)
    rewards = sum(i["reward_terms"]["tracking"] for i in infos)
    assert rewards < 0
    assert all(r["reward_terms"]["drop"] == 0 for r in infos)


def test_action_clipping_is_counted() -> None:
    env = GraspEnv("can")
    env.reset(seed=0)
    env.step(np.array([2.0], dtype=np.float32))
    env.step(np.array([0.5], dtype=np.float32))
    _, _, _, _, info = env.step(np.array([-3.0], dtype=np.float32))
    assert info["action_clipped_count"] == 2
    assert info["motor_command"] == -1.0


def test_crushing_the_egg_terminates_with_penalty() -> None:
    env = GraspEnv("egg", 2.0)
    env.reset(seed=0)
    for _ in range(200):
        _, reward, terminated, truncated, info = env.step(np.array([0.5], dtype=np.float32))
        if terminated:
            break
    assert terminated and info["crushed"] and not info["dropped"]
    assert max(info["grip_force_n"], info["finger_force_n"]) > 5.0
    assert info["reward_terms"]["crush"] == -100.0


def test_weak_grip_drops_the_can_after_lift() -> None:
    env = GraspEnv("can", 1.0, wrist=WristSchedule(lift_after_s=0.6))
    env.reset(seed=0)
    for k in range(300):
        u = 0.3 if k < 50 else 0.03  # close, then hold ~2.6 N < m g / (2 mu) = 3.8 N
        _, _, terminated, _, info = env.step(np.array([u], dtype=np.float32))
        if terminated:
            break
    assert terminated and info["dropped"] and info["lifted"]
    assert info["reward_terms"]["drop"] == -100.0


def test_nan_state_ends_episode_with_named_failure() -> None:
    env = GraspEnv("can")
    env.reset(seed=0)
    env.step(np.array([0.2], dtype=np.float32))
    env.data.qvel[0] = np.nan
    _, _, terminated, truncated, info = env.step(np.array([0.2], dtype=np.float32))
    assert truncated and "BADQVEL" in info["failure"]


def test_reference_kinds() -> None:
    profile = np.linspace(0.0, 9.9, 100)
    env = GraspEnv("ball", profile)
    env.reset(seed=0)
    for _ in range(5):
        obs, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert obs[0] == pytest.approx(profile[5], rel=1e-6)  # value at t = 50 ms

    env.reset(options={"reference": lambda t: 3.0 * t})
    obs, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert obs[0] == pytest.approx(0.03, rel=1e-5)

    rec = Recording(emg=np.zeros((40, 8), np.int8), fs_hz=20.0,
                    force_n=np.arange(40, dtype=float))
    env.reset(options={"reference": rec})
    for _ in range(10):
        obs, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert obs[0] == pytest.approx(2.0)  # t = 0.1 s -> sample 2 at 20 Hz

    env.set_reference(7.5)
    assert isinstance(env.reference, StreamReference)
    obs, *_ = env.step(np.zeros(1, dtype=np.float32))
    assert obs[0] == pytest.approx(7.5)

    with pytest.raises(ReferenceSignalError, match="reference"):
        env.reset(options={"reference": "ten newtons"})


def test_object_option_rebuilds_model() -> None:
    env = GraspEnv("ball")
    env.reset(seed=0, options={"object": {"name": "can", "mass_kg": 0.5}})
    assert env.model.body("object").mass[0] == pytest.approx(0.5)
    assert env.last_info["object_height_m"] == pytest.approx(0.061, abs=1e-3)


def test_constructor_validates() -> None:
    with pytest.raises(ValueError, match="control_dt_s"):
        GraspEnv(control_dt_s=0.003)
    with pytest.raises(ValueError, match="physics_dt_s"):
        GraspEnv(hand=HandSpec(physics_dt_s=0.005))


def test_reference_inputs_are_validated_at_the_boundary() -> None:
    from sim.references import ProfileReference, as_reference

    with pytest.raises(ReferenceSignalError, match="non-empty 1-D"):
        as_reference(np.zeros((3, 2)), 0.01)
    with pytest.raises(ReferenceSignalError, match=">= 0 N"):
        as_reference([1.0, -2.0], 0.01)
    with pytest.raises(ReferenceSignalError, match="no force_n"):
        as_reference(Recording(emg=np.zeros((5, 8), np.int8), fs_hz=200.0), 0.01)
    with pytest.raises(ReferenceSignalError, match="pushed reference"):
        StreamReference().push(float("nan"))
    ref = ProfileReference(np.array([1.0, 2.0, 3.0]), 0.1)
    assert [ref.value(t) for t in (0.0, 0.1, 0.25, 9.0)] == [1.0, 2.0, 3.0, 3.0]


def test_wrist_schedule_closed_forms() -> None:
    sch = WristSchedule(lift_height_m=0.08, lift_duration_s=0.6, shake_amplitude_m=0.01,
                        shake_frequency_hz=2.0, shake_delay_s=0.2, shake_duration_s=1.0,
                        place_delay_s=2.0)
    assert sch.height_m(5.0, None) == 0.0  # no grip, no lift
    assert sch.height_m(1.0, 1.0) == 0.0
    assert sch.height_m(1.3, 1.0) == pytest.approx(0.04)  # min-jerk midpoint
    assert sch.height_m(1.6, 1.0) == pytest.approx(0.08)
    # Shake: starts 0.2 s after the lift, sin^2 window (1 at mid-window) times sin.
    t_mid = 1.0 + 0.6 + 0.2 + 0.5
    assert sch.height_m(t_mid, 1.0) == pytest.approx(0.08)  # sin(2 pi 2 * 0.5) = 0
    t_peak = 1.0 + 0.6 + 0.2 + 0.5 + 0.125  # quarter period later
    window = np.sin(np.pi * 0.625) ** 2
    assert sch.height_m(t_peak, 1.0) == pytest.approx(0.08 + 0.01 * window)
    assert sch.height_m(1.0 + 0.6 + 2.0 + 0.6, 1.0) == pytest.approx(0.0)  # placed


def test_shaking_a_well_held_can_keeps_it() -> None:
    sch = WristSchedule(lift_after_s=0.6, shake_amplitude_m=0.01, shake_frequency_hz=3.0,
                        shake_delay_s=0.1, shake_duration_s=0.6)
    env = GraspEnv("can", 30.0, wrist=sch, task=GraspTask(episode_s=2.5))
    obs, _ = env.reset(seed=0)
    heights = []
    truncated = terminated = False
    while not (terminated or truncated):
        obs, _, terminated, truncated, info = env.step(np.array([0.35], dtype=np.float32))
        heights.append(info["object_height_m"])
    assert not terminated and not info["dropped"]
    shake = np.array(heights[140:200])  # during the shake window
    assert np.ptp(shake) > 0.01  # the object follows the wrist up and down
