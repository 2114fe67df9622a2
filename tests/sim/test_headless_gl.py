"""Importing ``sim`` picks headless EGL when no OpenGL backend is set and there is no display."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from sim import _choose_headless_gl

ROOT = Path(__file__).resolve().parents[2]
UNSET = ("MUJOCO_GL", "PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY")


@pytest.mark.parametrize(
    ("given", "platform", "expected"),
    [
        ({}, "linux", {"MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "egl"}),
        ({"MUJOCO_GL": "osmesa"}, "linux", {"MUJOCO_GL": "osmesa"}),  # explicit wins
        ({"MUJOCO_GL": "glfw", "DISPLAY": ":0"}, "linux", {"MUJOCO_GL": "glfw", "DISPLAY": ":0"}),
        ({"DISPLAY": ":0"}, "linux", {"DISPLAY": ":0"}),  # a display: MuJoCo's default
        ({"WAYLAND_DISPLAY": "wayland-0"}, "linux", {"WAYLAND_DISPLAY": "wayland-0"}),
        ({"PYOPENGL_PLATFORM": "osmesa"}, "linux",
         {"MUJOCO_GL": "egl", "PYOPENGL_PLATFORM": "osmesa"}),
        ({}, "darwin", {}),
    ],
    ids=["headless", "explicit", "explicit-display", "x11", "wayland", "pyopengl-kept", "macos"],
)
def test_choice(given, platform, expected):
    environ = dict(given)
    _choose_headless_gl(environ, platform)
    assert environ == expected


def test_rendering_without_mujoco_gl_set(tmp_path):
    """Python users render without setting anything (this used to abort the process)."""
    code = (
        "import os\n"
        "from sim.hand.grasp_env import GraspEnv\n"
        "env = GraspEnv('can', 15.0, render_mode='rgb_array', render_size=(60, 80))\n"
        "env.reset(seed=0)\n"
        "frame = env.render()\n"
        "env.close()\n"
        "print(os.environ['MUJOCO_GL'], frame.shape, float(frame.std()) > 0)\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in UNSET}
    env.update(PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=120)
    if proc.returncode and "EGL" in proc.stderr and "frame" not in proc.stdout:
        pytest.skip(f"no EGL here: {proc.stderr.strip().splitlines()[-1]}")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["egl", "(60,", "80,", "3)", "True"]
