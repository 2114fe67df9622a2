"""
The Gymnasium environment
=========================

``GraspEnv`` is a Gymnasium environment: the MuJoCo hand, an object on the table, and a
grip-force reference to track. ``gymnasium.make("griploop/GraspLift-v0")`` works as soon
as griploop is installed, with no import of griploop (rendering picks headless EGL when
there is no display). The action is the normalized motor command (-1..1); the
observation is the reference, the grip force, the finger's position and speed and the
motor current; physical readings (slip, drop, crush, object height) are in ``info``.
"""

# %%
# A random policy
# ---------------
import gymnasium as gym
import matplotlib.pyplot as plt
import numpy as np

env = gym.make("griploop/GraspLift-v0", render_mode="rgb_array")
obs, info = env.reset(seed=0)
print(env.observation_space)
print(env.action_space)

env.action_space.seed(0)
grip, reference = [], []
for _ in range(300):  # 3 s at the 100 Hz control rate
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    grip.append(info["grip_force_n"])
    reference.append(info["reference_n"])
    if terminated or truncated:
        break
print(f"after {info['time_s']:.2f} s: lifted {info['lifted']}, dropped {info['dropped']}, "
      f"slip events {info['slip_events']}")

# %%
# What it did
# -----------
# Random commands do not track the reference; a controller of griploop's, or a policy
# you train, does.
frame = env.render()
fig, (ax_t, ax_f) = plt.subplots(1, 2, figsize=(10, 3.8),
                                 gridspec_kw={"width_ratios": [3, 2]})
t_s = np.arange(1, len(grip) + 1) * env.unwrapped.control_dt_s
ax_t.plot(t_s, reference, label="reference")
ax_t.plot(t_s, grip, label="grip force")
ax_t.set_xlabel("time (s)")
ax_t.set_ylabel("N")
ax_t.legend()
ax_f.imshow(frame)
ax_f.set_axis_off()
fig.tight_layout()
env.close()
