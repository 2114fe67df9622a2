"""The simulated world: virtual users (muscles, electrodes, FSR) and the MuJoCo hand.

``sim`` imports none of the other griploop packages.

Rendering: MuJoCo picks its OpenGL backend when it is first imported, and GLFW
without a display aborts the process. So when ``MUJOCO_GL`` is unset and there
is no display (Linux, no ``DISPLAY`` or ``WAYLAND_DISPLAY``), importing ``sim``
selects headless EGL (``MUJOCO_GL=egl``, ``PYOPENGL_PLATFORM=egl``) before
MuJoCo loads. An explicit ``MUJOCO_GL`` always wins.
"""

import os as _os
import sys as _sys


def _choose_headless_gl(environ=None, platform: str = _sys.platform) -> None:
    """Select EGL when no OpenGL backend is set and no display exists (Linux only).

    ``environ`` is a mutable mapping of environment variables (default ``os.environ``).
    """
    environ = _os.environ if environ is None else environ
    if environ.get("MUJOCO_GL") or not platform.startswith("linux"):
        return
    if environ.get("DISPLAY") or environ.get("WAYLAND_DISPLAY"):
        return
    environ["MUJOCO_GL"] = "egl"
    environ.setdefault("PYOPENGL_PLATFORM", "egl")


_choose_headless_gl()

from sim.hand import registration as _registration  # noqa: E402, F401  (griploop/GraspLift-v0)
from sim.recording import Recording, RecordingError, load_recording  # noqa: E402
from sim.user.intent import IntentProfile, grasp_lift_hold, paper_protocol, ramp_profile  # noqa: E402
from sim.user.subjects import GENERATORS, VirtualSubject, make_population  # noqa: E402

__all__ = ["Recording", "RecordingError", "load_recording"]
__all__ += ["GENERATORS", "IntentProfile", "VirtualSubject", "grasp_lift_hold", "make_population",
            "paper_protocol", "ramp_profile"]
