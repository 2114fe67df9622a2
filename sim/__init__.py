"""The simulated world: virtual users (muscles, electrodes, FSR) and the MuJoCo hand.

``sim`` imports none of the other griploop packages.

Rendering: MuJoCo picks its OpenGL backend when it is first imported, and GLFW
without a display aborts the process. So when ``MUJOCO_GL`` is unset and there
is no display (Linux, no ``DISPLAY`` or ``WAYLAND_DISPLAY``), importing ``sim``
selects headless EGL (``MUJOCO_GL=egl``, ``PYOPENGL_PLATFORM=egl``) before
MuJoCo loads. An explicit ``MUJOCO_GL`` always wins.

Two worlds that import nothing from each other: :mod:`sim.user` (the virtual
user: muscles, sEMG, armband, FSR, intent protocols) and :mod:`sim.hand` (the
MuJoCo hand, objects, contacts, ``GraspEnv``, linearization). Both may use
:mod:`sim.recording` and :mod:`sim.references`, :mod:`sim.errors` holds the
base of every griploop error and :mod:`sim.registry` the named registries every
extension family uses (sEMG generators in :mod:`sim.user.generators`, objects in
:mod:`sim.hand.objects`). Importing :mod:`sim.hand` registers the
Gymnasium id ``griploop/GraspLift-v0``.
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

from sim.lazy import lazy_exports  # noqa: E402

#: Public names, imported on first use so that ``import sim`` (and
#: :class:`sim.errors.GriploopError`) stays light: ``name -> module``.
_LAZY = {
    "Recording": "sim.recording", "RecordingError": "sim.recording",
    "load_recording": "sim.recording",
    "GraspLiftTiming": "sim.user.intent", "IntentProfile": "sim.user.intent",
    "grasp_lift_hold": "sim.user.intent",
    "paper_protocol": "sim.user.intent", "ramp_profile": "sim.user.intent",
    "GENERATORS": "sim.user.subjects", "VirtualSubject": "sim.user.subjects",
    "make_population": "sim.user.subjects",
}
__all__ = sorted(_LAZY)


__getattr__ = lazy_exports(__name__, _LAZY)
