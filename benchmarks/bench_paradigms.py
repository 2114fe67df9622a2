"""A trial under every paradigm, drive and auto-grip against today's, interleaved (issue 35).

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_paradigms.py [--rounds 5]``

Goal: a trial under any paradigm and drive, with or without the hand's slip response,
costs at most 1.1 times a ``force`` trial on the backdrivable drive, in wall time per
simulated second. The trial is a novice's grasp-lift-hold of the can (ss_kf free run,
PID; seeds 0-2 of subject 1), the calibration and the designs warm; every round runs
every hand once, in an order that rotates from round to round, and each hand's ratio is
taken within its round against the ``force``/``backdrivable`` trial of that round
(the same process, machine and load). The goal line states the largest, over hands, of
each hand's median ratio over the rounds; the CPU-time ratio is printed beside it.

The trials of different hands are different trials (the hand holds or hunts, the user
reacts), so their cost per simulated second also measures what they do. The second goal
isolates the drive's own cost: the hand environment stepped with the same command
sequences (a steady squeeze and a squeeze switching by +-0.12 every 50 ms, 15 s each
after a 1.5 s close), self-locking against backdrivable, interleaved, at most 1.1 times.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")
sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

LIMIT = 1.1
HANDS = [(p, d, g) for p in ("force", "force_hold") for d in ("backdrivable", "self_locking")
         for g in (False, True)]
SEEDS = (0, 1, 2)


def _trials(hand: tuple[str, str, bool]) -> tuple[float, float]:
    """Wall and CPU seconds per simulated second of the trials of one hand."""
    from scenarios.runners.episode import EpisodeSpec, run_episode
    from scenarios.runners.trial_loop import HandSettings
    from sim.hand.objects import make_object
    from sim.user.subjects import VirtualSubject

    subject, can = VirtualSubject.sample(0, 1), make_object("can", mass_kg=0.4, friction=0.5)
    wall = cpu = sim = 0.0
    for seed in SEEDS:
        spec = EpisodeSpec(estimator="ss_kf", controller="pid", seed=seed, practice=0,
                           hand=HandSettings(hand[1], hand[0], hand[2]))
        t0, c0 = time.perf_counter(), time.process_time()
        row = run_episode(subject, can, spec).row
        wall += time.perf_counter() - t0
        cpu += time.process_time() - c0
        sim += row["simulated_s"]
    return wall / sim, cpu / sim


def _env_step_us(drive: str, commands: np.ndarray) -> float:
    """Microseconds per control step of the hand environment on ``commands``."""
    from sim.hand.grasp_env import GraspEnv, GraspTask, HandSpec

    env = GraspEnv("can", 0.0, hand=HandSpec(drive=drive), task=GraspTask(episode_s=60.0))
    env.reset(seed=0)
    action = np.zeros(1, dtype=np.float32)
    t0 = time.perf_counter()
    for u in commands:
        action[0] = u
        env.step(action)
    elapsed = time.perf_counter() - t0
    env.close()
    return 1e6 * elapsed / len(commands)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="interleaved rounds (default 5)")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    for hand in HANDS:  # warm: calibration, designs (with and without the reflex)
        _trials(hand)
    ratios: dict[tuple, list[tuple[float, float]]] = {h: [] for h in HANDS[1:]}
    base_ms = []
    for r in range(args.rounds):
        order = HANDS[r % len(HANDS):] + HANDS[:r % len(HANDS)]
        times = {h: _trials(h) for h in order}
        base = times[HANDS[0]]
        base_ms.append(1e3 * base[0])
        for h in HANDS[1:]:
            ratios[h].append((times[h][0] / base[0], times[h][1] / base[1]))
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    for h, rs in ratios.items():
        print(f"{h[0]:<10} {h[1]:<12} auto-grip {'on ' if h[2] else 'off'}: wall "
              f"{statistics.median(r[0] for r in rs):.3f} x, CPU "
              f"{statistics.median(r[1] for r in rs):.3f} x (rounds "
              f"{min(r[0] for r in rs):.3f}-{max(r[0] for r in rs):.3f})")
    wall = {h: statistics.median(r[0] for r in rs) for h, rs in ratios.items()}
    worst = max(wall, key=wall.get)
    goal_line(f"a trial under any paradigm, drive and auto-grip costs <= {LIMIT:g} x a force "
              f"trial on the backdrivable drive (the costliest hand's median of "
              f"{args.rounds} interleaved rounds)", wall[worst], "x", limit=LIMIT,
              reference=f"force/backdrivable {statistics.median(base_ms):.1f} ms per simulated "
              f"s; costliest {'/'.join(map(str, worst))}, CPU-time ratio "
              f"{statistics.median(r[1] for r in ratios[worst]):.3f}")
    k = np.arange(1500)
    sequences = {"steady": np.r_[np.full(150, 0.3), 0.15 + 0.05 * np.sin(k / 7)],
                 "switching": np.r_[np.full(150, 0.3), 0.1 + 0.12 * np.sign(np.sin(k / 5))]}
    step_ratios = {name: [] for name in sequences}
    for r in range(args.rounds):
        for name, commands in sequences.items():
            drives = ("backdrivable", "self_locking")[::1 if r % 2 == 0 else -1]
            us = {d: _env_step_us(d, commands) for d in drives}
            step_ratios[name].append(us["self_locking"] / us["backdrivable"])
    medians = {name: statistics.median(rs) for name, rs in step_ratios.items()}
    worst_seq = max(medians, key=medians.get)
    goal_line(f"the self-locking drive's hand step costs <= {LIMIT:g} x the backdrivable one's "
              f"on the same commands (the costlier sequence's median of {args.rounds} "
              f"interleaved rounds)", medians[worst_seq], "x", limit=LIMIT,
              reference=", ".join(f"{n} {m:.3f} x" for n, m in medians.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
