"""Feature extraction speed: vectorized MAV/RMS/WL versus a plain per-window Python loop.

Run: ``.venv/bin/python benchmarks/bench_features.py``

Measures both on the same 10-minute, 8-channel, 200 Hz int8 recording (400 ms
windows every 125 ms), checks the outputs are identical, and prints the ratio.
Goal: ratio >= 1000.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line, time_call  # noqa: E402

from estimation.features import emg_features, window_samples  # noqa: E402


def plain_loop(emg: np.ndarray, win: int, step: int) -> list[list[float]]:
    """The paper's equations 1-3, window by window, channel by channel, in pure Python."""
    data = emg.T.tolist()
    out = []
    for start in range(0, emg.shape[0] - win + 1, step):
        row = []
        for ch in data:
            w = ch[start:start + win]
            row.append(sum(abs(v) for v in w) / win)
            row.append((sum(v * v for v in w) / win) ** 0.5)
            row.append(sum(abs(w[k] - w[k - 1]) for k in range(1, win)))
        out.append(row)
    return out


def main() -> None:
    fs_hz = 200.0
    rng = np.random.default_rng(0)
    emg = np.clip(rng.normal(0, 12, size=(int(600 * fs_hz), 8)), -128, 127).astype(np.int8)
    win, step = window_samples(fs_hz, 400, 125)
    start = time.perf_counter()
    reference = np.array(plain_loop(emg, win, step))
    t_loop = time.perf_counter() - start
    fast = emg_features(emg, fs_hz)
    identical = np.allclose(fast, reference, rtol=1e-12, atol=1e-9)
    t_fast = time_call(lambda: emg_features(emg, fs_hz))
    print("command: .venv/bin/python benchmarks/bench_features.py")
    print(f"recording: 10 min, 8 ch, {fs_hz:.0f} Hz int8, {fast.shape[0]} windows")
    print(f"plain per-window Python loop: {t_loop * 1e3:9.1f} ms")
    print(f"vectorized emg_features:      {t_fast * 1e3:9.3f} ms")
    print(f"speed-up: {t_loop / t_fast:,.0f}x (goal >= 1000x); outputs identical: {identical}")
    goal_line("vectorized MAV/RMS/WL features >= 1000x a per-window Python loop",
              t_loop / t_fast, "x", limit=1000.0, better="higher",
              reference=f"plain loop {t_loop * 1e3:.0f} ms, vectorized {t_fast * 1e3:.2f} ms")
    if not identical:
        raise SystemExit("outputs differ")


if __name__ == "__main__":
    main()
