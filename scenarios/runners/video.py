"""Animated GIFs of rendered episodes (Pillow, which matplotlib already requires)."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_video(frames: np.ndarray, path: str | Path, *, fps: float = 25.0) -> Path:
    """Write RGB frames as an animated GIF.

    Parameters
    ----------
    frames : ndarray, shape (n_frames, height, width, 3), uint8
    path : str or Path
        Output file; must end in ``.gif``.
    fps : float
        Frames per second.
    """
    path = Path(path)
    arr = np.asarray(frames)
    if arr.ndim != 4 or arr.shape[-1] != 3 or arr.dtype != np.uint8 or arr.shape[0] == 0:
        raise ValueError(f"frames: expected (n, height, width, 3) uint8, found {arr.shape} "
                         f"{arr.dtype}")
    if path.suffix.lower() != ".gif":
        raise ValueError(f"{path}: expected a .gif file")
    from PIL import Image

    images = [Image.fromarray(f) for f in arr]
    path.parent.mkdir(parents=True, exist_ok=True)
    images[0].save(path, save_all=True, append_images=images[1:], loop=0,
                   duration=int(round(1000.0 / fps)))
    return path
