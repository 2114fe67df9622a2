"""Render a frame of the hand holding an object (the README picture).

Usage::

    python -m sim.hand.render_snapshot docs/grasp.png [--object ball] [--grip 10]

The hand closes on the object, lifts it and holds it at the requested grip
force (``GraspEnv.steady_grasp``); the frame comes from the ``front`` camera.
Without a display, importing :mod:`sim` has already chosen headless EGL.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def render_grasp(object: str = "ball", grip_force_n: float = 10.0,
                 size: tuple[int, int] = (480, 640)) -> np.ndarray:
    """An RGB frame ``(height, width, 3)`` uint8 of a lifted, held object."""
    from sim.hand.grasp_env import GraspEnv

    env = GraspEnv(object, grip_force_n, render_mode="rgb_array", render_size=size)
    try:
        env.reset(seed=0)
        env.steady_grasp(grip_force_n, lifted=True)
        return env.render()
    finally:
        env.close()


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(description="Render the hand holding an object.")
    parser.add_argument("out", type=Path, help="PNG file to write")
    parser.add_argument("--object", default="ball")
    parser.add_argument("--grip", type=float, default=10.0, help="grip force, N")
    args = parser.parse_args(argv)
    from PIL import Image  # Pillow (matplotlib's dependency): no matplotlib import to save a PNG

    frame = render_grasp(args.object, args.grip)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(frame).save(args.out)
    print(f"wrote {args.out} ({frame.shape[1]}x{frame.shape[0]})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
