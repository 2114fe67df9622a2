"""``griploop stream`` players in their own processes, for the LSL loopback tests
(imported by the test modules as ``lsl_players``)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path


class Streamer:
    """``griploop stream FILE`` in its own process (as a lab's player or armband would be)."""

    def __init__(self, path: Path, name: str, *extra: str) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "scenarios.cli", "stream", str(path), "--name", name, *extra],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.lines: list[str] = []

    def wait_for(self, text: str, timeout_s: float = 30.0) -> str:
        """Read the player's output until a line containing ``text``; that line."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            self.lines.append(line)
            if text in line:
                return line
        raise AssertionError(f"the player never said {text!r}: {self.lines}")

    def __enter__(self) -> Streamer:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
        self.output = "".join(self.lines) + self.proc.communicate(timeout=10)[0]
