"""The practised user's cost: a measured trial, the practice itself, and the eggs benchmark.

Goals (issue 27, "Speed"):

1. a measured trial of a practised user, practice cached, costs at most 1.3 x the wall
   time of griploop 0.4's reacting episode of the same length. The reference is measured
   in the same run: the same reacting user whose arm is not theirs (the wrist lifts on
   the scripted schedule, as every reacting episode of 0.4 did; :class:`ScheduledArm`),
   on an episode as long as the practised trial lasted, the same subject, object,
   estimator, controller and seed. Both are timed per simulated second (an episode that
   loses the object ends early), interleaved (``--repeat`` pairs, which one goes first
   alternating; the figure is the median of the pairs' ratios), design cache,
   calibration and practice warm;
2. practice itself (5 lifts) costs at most 3 s per subject and interface on one core
   (the practice cache off, calibration and design warm; median of ``--repeat``);
3. ``griploop eggs`` with 5 subjects, 11 eggs, 2 feedback modes and 2 workers in at most
   3 minutes (the command as a user runs it, in a child process; plant, design and
   practice caches in a fresh directory, so the first designs and practices are paid).

Run::

    .venv/bin/python benchmarks/bench_operator.py [--repeat 7] [--skip-eggs]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _timing import goal_line  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")

#: (name, subject, object): the episode of issue 20 (the can, subject 1) and the block
CASES = (("subject 1, can", 1, "can"), ("subject 3, block", 3, "block"))
ESTIMATOR, CONTROLLER, SEED = "latent_kf", "pid", 1


def _scheduled_arm() -> type:
    """The reacting user whose wrist follows the schedule: griploop 0.4's reacting episode."""
    from sim.user.reacting import ReactingOperator
    from sim.user.scripted import ScriptedArm

    class ScheduledArm(ReactingOperator):
        """Sees, feels and corrects, but the arm lifts as the scripted user's does (at a set
        time once the grip is established) and the trial runs to its limit."""

        name = "scheduled_arm"
        done = property(lambda self: False, lambda self, value: None)

        def start(self, plan, *, control_dt_s, rng):  # type: ignore[no-untyped-def]
            super().start(plan, control_dt_s=control_dt_s, rng=rng)
            self.script_arm = ScriptedArm(self.params.lift_s)
            self.script_arm.start(plan)

        def perceive(self, scene):  # type: ignore[no-untyped-def]
            super().perceive(scene)
            self.script_arm.perceive(scene)

        def wrist_move(self):  # type: ignore[no-untyped-def]
            super().wrist_move()  # the user's own decision, not carried out
            return self.script_arm.wrist_move()

    return ScheduledArm


def trial_times(repeat: int) -> list[tuple[str, float, float, float, float]]:
    """Per case: practised trial and reference wall times (medians), their ratio, the length."""
    from scenarios.runners.episode import EpisodeSpec, run_episode
    from sim.hand.objects import make_object
    from sim.user.operators import register_operator, unregister_operator
    from sim.user.subjects import VirtualSubject

    register_operator("scheduled_arm", _scheduled_arm())
    out = []
    try:
        for name, subject_id, object_name in CASES:
            subject, obj = VirtualSubject.sample(0, subject_id), make_object(object_name)

            def run(user: str, episode_s: float | None, subject=subject, obj=obj
                    ) -> tuple[float, dict]:
                """Wall time per simulated second of one episode, and its row."""
                t0 = time.perf_counter()
                r = run_episode(subject, obj, EpisodeSpec(estimator=ESTIMATOR,
                                                          controller=CONTROLLER, seed=SEED,
                                                          user=user, episode_s=episode_s))
                return (time.perf_counter() - t0) / r.row["simulated_s"], r.row

            _, row = run("reacting", None)  # warm: design, calibration, practice cache
            length = row["simulated_s"]
            run("scheduled_arm", length)
            times: dict[str, list[float]] = {"reacting": [], "scheduled_arm": []}
            for i in range(repeat):
                users = ("reacting", "scheduled_arm") if i % 2 == 0 else ("scheduled_arm",
                                                                           "reacting")
                for user in users:
                    dt, _ = run(user, None if user == "reacting" else length)
                    times[user].append(dt)
            ratio = statistics.median(a / b for a, b in zip(times["reacting"],
                                                            times["scheduled_arm"],
                                                            strict=True))
            print(f"{name}: practised trial {row['outcome']}, {length:.2f} s simulated, "
                  f"{row['attempts']} attempt(s)", flush=True)
            out.append((name, statistics.median(times["reacting"]),
                        statistics.median(times["scheduled_arm"]), ratio, length))
    finally:
        unregister_operator("scheduled_arm")
    return out


def practice_time(repeat: int) -> float:
    """Median wall time of 5 practice lifts (cache off; calibration and design warm), s."""
    import numpy as np

    from scenarios.runners import practice as P
    from scenarios.runners.calibration import CalibrationSettings
    from sim.hand.objects import make_object
    from sim.user.operator import OperatorParams
    from sim.user.subjects import VirtualSubject

    subject = VirtualSubject.sample(0, 1)
    settings = CalibrationSettings(ESTIMATOR, "free_run")
    cal_seq, practice_seq = np.random.SeedSequence(SEED).spawn(2)
    cal = settings.fit(subject, cal_seq)
    interface = P.Interface(settings, CONTROLLER, {}, make_object("can"), "reacting", "none",
                            OperatorParams(), 0.01, 30.0)
    previous = os.environ.get("GRIPLOOP_CACHE_DIR")
    os.environ["GRIPLOOP_CACHE_DIR"] = "off"  # the practice itself, not its cache
    try:
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            P.practised_belief(subject, cal, interface, cal_seq=cal_seq,
                               n_lifts=P.DEFAULT_PRACTICE, seed_seq=practice_seq,
                               trial_s=15.0)
            times.append(time.perf_counter() - t0)
    finally:
        if previous is None:
            os.environ.pop("GRIPLOOP_CACHE_DIR")
        else:
            os.environ["GRIPLOOP_CACHE_DIR"] = previous
    return statistics.median(times)


def eggs_time() -> float:
    """Wall time of ``griploop eggs`` (5 subjects, 11 eggs, 2 modes, 2 workers), s."""
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "GRIPLOOP_CACHE_DIR": str(Path(tmp) / "cache")}
        cmd = [str(Path(sys.executable).parent / "griploop"), "eggs", "--controller", "pid",
               "--estimator", "latent_kf", "--feedback", "none,force_vibration",
               "--subjects", "5", "--workers", "2", "--db", str(Path(tmp) / "eggs.sqlite"),
               "--json", str(Path(tmp) / "eggs.json"), "--no-progress"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL)
        return time.perf_counter() - t0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--skip-eggs", action="store_true")
    args = parser.parse_args()
    for name, practised, reference, ratio, length in trial_times(args.repeat):
        goal_line(f"practised trial / 0.4's reacting episode of the same length <= 1.3 "
                  f"({name}, {length:.1f} s)", ratio, "x", limit=1.3,
                  reference=f"scheduled arm {1e3 * reference:.1f} ms, practised "
                  f"{1e3 * practised:.1f} ms per simulated s")
    seconds = practice_time(max(3, args.repeat // 2))
    goal_line("practice, 5 lifts, one subject and interface, one core <= 3 s", seconds, "s",
              limit=3.0)
    if not args.skip_eggs:
        goal_line("eggs: 5 subjects x 11 eggs x 2 modes, 2 workers <= 180 s", eggs_time(), "s",
                  limit=180.0)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
