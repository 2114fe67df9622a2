"""Section 9 of the report: one frame of the hand holding the sweep's most common object.

Rendered in a child process while the other sections are built.
"""

from __future__ import annotations

import re
import subprocess
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from scenarios.report import data as D
from scenarios.report.html import (
    Section,
    img,
    note,
)

FRAME_GRIP_N = 10.0


# ---------------------------------------------------------------- 9. frame


class FrameRender:
    """A PNG of the hand holding an object (``sim.hand.render_snapshot``), rendered in a
    child process started at construction, so the report builds its sections meanwhile.

    MuJoCo picks its OpenGL backend when first imported, and the child, importing
    :mod:`sim` first, gets a headless one when there is no display (whatever this
    process loaded); the child also keeps a GL crash out of the report.

    Parameters
    ----------
    name : str
        Object name.
    grip_force_n : float
        Grip force held, N.
    timeout_s : float
        Longest wait in :meth:`result`, s.
    """

    def __init__(self, name: str, grip_force_n: float, timeout_s: float = 120.0) -> None:
        self.name = name
        self.timeout_s = timeout_s
        self._tmp = tempfile.TemporaryDirectory(prefix="griploop-frame-")
        self._out = Path(self._tmp.name) / "grasp.png"
        cmd = [sys.executable, "-m", "sim.hand.render_snapshot", str(self._out), "--object",
               name, "--grip", f"{grip_force_n:.6g}"]
        self._proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                      stdin=subprocess.DEVNULL, text=True)
        self._outcome: bytes | RuntimeError | None = None

    def result(self) -> bytes:
        """The PNG bytes (waits for the child).

        Raises
        ------
        RuntimeError
            The renderer exited with an error or timed out (message: its last line).
        """
        if self._outcome is None:
            self._outcome = self._collect()
            self.cancel()
        if isinstance(self._outcome, RuntimeError):
            raise self._outcome
        return self._outcome

    def _collect(self) -> bytes | RuntimeError:
        try:
            stdout, stderr = self._proc.communicate(timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            return RuntimeError(f"renderer timed out after {self.timeout_s:g} s")
        if self._proc.returncode != 0 or not self._out.is_file():
            lines = (stderr or stdout).strip().splitlines()
            errors = [ln for ln in lines if re.match(r"[\w.]+(Error|Exception)\b", ln)]
            last = errors[-1] if errors else lines[-1] if lines else ""
            return RuntimeError(last or f"renderer exit status {self._proc.returncode}")
        return self._out.read_bytes()

    def cancel(self) -> None:
        """Stop the child if it still runs, reap it and remove its files (no effect when
        done)."""
        if self._proc.poll() is None:
            self._proc.kill()
        self._proc.communicate()  # closes its pipes
        self._tmp.cleanup()


def render_frame_png(name: str, grip_force_n: float, timeout_s: float = 120.0) -> bytes:
    """PNG of the hand holding ``name`` at ``grip_force_n`` N (:class:`FrameRender`, waited for).

    Raises
    ------
    RuntimeError
        The renderer exited with an error or timed out (message: its last line).
    """
    job = FrameRender(name, grip_force_n, timeout_s)
    try:
        return job.result()
    finally:
        job.cancel()


def frame_section(episodes: Sequence[dict], render: bool, job: FrameRender | None = None
                   ) -> Section:
    title = "9. Rendered grasp"
    if not render:
        return Section("frame", title, note("Rendering switched off (--no-render)."), True)
    name = job.name if job is not None else D.most_common_object(episodes)
    try:
        png = job.result() if job is not None else render_frame_png(name, FRAME_GRIP_N)
    except RuntimeError as exc:
        return Section("frame", title, note(f"Rendering {name} failed: {exc}"), True)
    source = "most common object of the episodes" if episodes else "no episodes: default object"
    body = (note(f"{name} ({source}), lifted and held at {FRAME_GRIP_N:g} N, front camera; "
                 "the frame shows the object and hand, not a particular episode.")
            + img(png, f"rendered grasp of {name}"))
    return Section("frame", title, body)
