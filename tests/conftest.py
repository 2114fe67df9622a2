"""Suite-wide setup: headless rendering backends, chosen before mujoco or matplotlib load."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])
os.environ.setdefault("MPLBACKEND", "Agg")
