"""Showing the hand of a live session: the MuJoCo viewer, or a GIF rendered afterwards.

Rendering a frame headless (Mesa's llvmpipe through EGL) takes 30-90 ms with
MuJoCo's shadows and reflections on the project's 2-core machine, far more than a
control period, so a headless session only stores the hand's joint positions every
40 ms of session time; :func:`render_states` replays them into the same model after
the session, without shadows and reflections (about 7 ms a frame at 240 x 320), and
writes the GIF (about 2 s for an 8 s session). With a display, :class:`Viewer`
opens MuJoCo's passive viewer on the session's own model and data and syncs it every
40 ms (the viewer renders in its own thread).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sim.hand.objects import ObjectSpec

FRAME_DT_S = 0.04
"""Session time between states stored for the GIF, s (25 frames per second)."""
CRUSHED_RGBA = (0.3, 0.25, 0.2, 1.0)


def has_display() -> bool:
    """Whether an X11 or Wayland display is available."""
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


class Viewer:
    """MuJoCo's passive viewer on a session's model and data.

    Use :meth:`open`, which returns ``None`` when the viewer cannot start.
    """

    def __init__(self, handle: Any) -> None:
        self.handle = handle

    @classmethod
    def open(cls, env: Any) -> Viewer | None:
        """The viewer on ``env``'s model and data, or ``None`` (no display, no GLFW)."""
        if not has_display():
            return None
        try:
            import mujoco.viewer

            return cls(mujoco.viewer.launch_passive(env.model, env.data, show_left_ui=False,
                                                    show_right_ui=False))
        except Exception:  # noqa: BLE001 - any failure means: render a GIF instead
            return None

    def sync(self) -> None:
        """Show the current state (if the window is still open)."""
        if self.handle.is_running():
            self.handle.sync()

    def close(self) -> None:
        """Close the window."""
        self.handle.close()


def render_states(obj: ObjectSpec, states: Sequence[tuple[np.ndarray, bool]], path: str | Path,
                  *, fps: float = 1.0 / FRAME_DT_S, size: tuple[int, int] = (240, 320)) -> Path:
    """Render stored hand states to an animated GIF.

    Parameters
    ----------
    obj : ObjectSpec
        The session's object (the model is rebuilt from it).
    states : sequence of (qpos, crushed)
        Joint positions of the session's model and whether the object was crushed.
    path : str or Path
        Output ``.gif``.
    fps : float
        Frames per second (default: real time for states stored every 40 ms).
    size : (height, width)
        Frame size in pixels.
    """
    import mujoco

    from sim.hand.grasp_env import GraspEnv

    if not states:
        raise ValueError("render_states: no states to render")
    env = GraspEnv(obj, 0.0)
    env.reset(seed=0)
    m, d = env.model, env.data
    renderer = mujoco.Renderer(m, height=size[0], width=size[1])
    off = (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION)
    try:
        frames = []
        for qpos, crushed in states:
            d.qpos[:] = qpos
            if crushed:
                m.geom_rgba[env.ids.object_geom] = CRUSHED_RGBA
            mujoco.mj_forward(m, d)
            renderer.update_scene(d, camera="front")
            for flag in off:
                renderer.scene.flags[flag] = False
            frames.append(renderer.render())
    finally:
        renderer.close()
        env.close()
    return write_gif(frames, path, fps=fps)


def write_gif(frames: Sequence[np.ndarray], path: str | Path, *, fps: float) -> Path:
    """An animated GIF of RGB frames ``(height, width, 3)`` uint8, one palette for all.

    The palette is the first frame's (median cut, 256 colours) and no frame is
    dithered: a tenth of the time of a palette per frame, for a scene whose colours
    do not change.
    """
    from PIL import Image

    path = Path(path)
    images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
    palette = images[0].quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    indexed = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in images]
    path.parent.mkdir(parents=True, exist_ok=True)
    indexed[0].save(path, save_all=True, append_images=indexed[1:], loop=0,
                    duration=int(round(1000.0 / fps)))
    return path
