"""Closed-loop episode speed: PID + streaming estimator, with the time split by stage.

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_episode.py``

Runs the same 6 s grasp-lift-hold of the can (0.4 kg, mu 0.5) for several
seeds with the ss_kf estimator in free run and a PID at 100 Hz, after one
warm-up episode (design plants are cached per object). Reports the simulated
time over the wall time of the episode proper (sEMG generation, features,
estimator, controller, physics) and of the one-off calibration (session, fit).
Goal (issue 5): at least 50x faster than real time on one core.
"""

from __future__ import annotations

import time

import numpy as np

from scenarios.runners.episode import run_episode
from sim.hand.objects import make_object
from sim.user.subjects import VirtualSubject

STAGES = ("t_semg_s", "t_features_s", "t_estimator_s", "t_controller_s", "t_physics_s")


def main() -> None:
    subject = VirtualSubject.sample(0, 1)
    can = make_object("can", mass_kg=0.4, friction=0.5)
    run_episode(subject, can, estimator="ss_kf", controller="pid", seed=0)  # warm-up
    totals = dict.fromkeys(STAGES, 0.0)
    simulated = wall = 0.0
    seeds = range(1, 9)
    for seed in seeds:
        start = time.perf_counter()
        row = run_episode(subject, can, estimator="ss_kf", controller="pid", seed=seed).row
        wall += time.perf_counter() - start
        simulated += row["simulated_s"]
        for k in STAGES:
            totals[k] += row[k]
    loop = sum(totals.values())
    print("command: MUJOCO_GL=egl .venv/bin/python benchmarks/bench_episode.py")
    print(f"{len(seeds)} episodes, {simulated:.1f} s simulated, ss_kf free_run + PID at 100 Hz")
    for k in STAGES:
        print(f"  {k[2:-2]:<11} {totals[k] * 1e3 / len(seeds):8.1f} ms/episode "
              f"({100 * totals[k] / loop:4.1f} %)")
    print(f"episode loop: {simulated / loop:6.1f}x real time (goal >= 50x)")
    print(f"whole call incl. calibration session and fit: {simulated / wall:6.1f}x real time")
    print(f"per control step: {1e6 * loop / (simulated / 0.01):.0f} us "
          f"(physics {1e6 * totals['t_physics_s'] / (simulated / 0.01):.0f} us)")
    assert np.isfinite(loop)


if __name__ == "__main__":
    main()
