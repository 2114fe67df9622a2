"""A ``velocity`` trial against a ``force`` trial, interleaved (issue 36).

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_velocity.py [--rounds 5]``

Goal: a trial under ``velocity`` (its decoder's second feature window and stream, the
user's open intent, the bounded motor command) costs at most 1.1 times a ``force`` trial,
in wall time per simulated second. Both run on the self-locking drive, so the ratio is the
paradigm's and its decoder's cost, not the drive's (issue 35 measured that). The trials
are a novice's grasp-lift-hold of the can (ss_kf free run, PID; seeds 0-2 of subject 1),
the calibrations and designs warm; each round runs both, in an order that alternates, and
the ratio is taken within the round. The trials differ (a velocity hand closes and opens
at the signals' speeds), so their cost per simulated second also measures what they do.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

LIMIT = 1.1
SEEDS = (0, 1, 2)
PARADIGMS = ("force", "velocity")


def _trials(paradigm: str) -> tuple[float, float]:
    """Wall and CPU seconds per simulated second of the trials under ``paradigm``."""
    from scenarios.runners.episode import EpisodeSpec, run_episode
    from scenarios.runners.trial_loop import HandSettings
    from sim.hand.objects import make_object
    from sim.user.subjects import VirtualSubject

    subject, can = VirtualSubject.sample(0, 1), make_object("can", mass_kg=0.4, friction=0.5)
    wall = cpu = sim = 0.0
    for seed in SEEDS:
        spec = EpisodeSpec(estimator="ss_kf", controller="pid", seed=seed, practice=0,
                           hand=HandSettings("self_locking", paradigm))
        t0, c0 = time.perf_counter(), time.process_time()
        row = run_episode(subject, can, spec).row
        wall += time.perf_counter() - t0
        cpu += time.process_time() - c0
        sim += row["simulated_s"]
    return wall / sim, cpu / sim


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds (default 5)")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for paradigm in PARADIGMS:  # warm: calibrations with and without the decoder, designs
        _trials(paradigm)
    ratios, base_ms = [], []
    for r in range(args.rounds):
        order = PARADIGMS if r % 2 == 0 else PARADIGMS[::-1]
        times = {p: _trials(p) for p in order}
        base_ms.append(1e3 * times["force"][0])
        ratios.append((times["velocity"][0] / times["force"][0],
                       times["velocity"][1] / times["force"][1]))
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    wall = statistics.median(r[0] for r in ratios)
    goal_line(f"a velocity trial costs <= {LIMIT:g} x a force trial, both on the self-locking "
              f"drive (median of {args.rounds} interleaved rounds)", wall, "x", limit=LIMIT,
              reference=f"force {statistics.median(base_ms):.1f} ms per simulated s; rounds "
              f"{min(r[0] for r in ratios):.3f}-{max(r[0] for r in ratios):.3f}, CPU-time "
              f"ratio {statistics.median(r[1] for r in ratios):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
