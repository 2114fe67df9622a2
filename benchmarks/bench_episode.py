"""Closed-loop episode speed: the episode loop in-process, and whole `griploop` processes.

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_episode.py [--repeat 5]``

Goals:

- the episode loop (sEMG generation, features, estimator, the user's
  decisions, controller, physics) runs at least 50x faster than real time on
  one core, with the default (reacting) user; the scripted user's loop is
  printed as the reference. The same 6 s
  grasp-lift-hold of the can (0.4 kg, mu 0.5) with the ss_kf estimator in free
  run and a PID at 100 Hz, for several seeds, after one warm-up episode.
- a whole ``griploop episode --controller pid --estimator ss_kf
  --object can`` process takes at most 1.5 s of wall time with a warm disk
  cache (plant family and controller design with its margins on disk, from an
  earlier run), and ``griploop --help`` at most 0.5 s.

The processes run ``python -m scenarios.cli`` of this tree with a fresh cache
directory warmed by one untimed run; each command is timed ``--repeat``
times, interleaved, and the best time is the figure (timeit's convention: the
slower runs measure the machine's other jobs; the median is printed too). Printed next to them, from
the same run: the episode process with the design cache off (designs and
margins made again, as without the design cache: the reference), and the import of the
episode command alone (what no cache can save). Main, before the design cache and the lazy imports,
measured 3.66 s for the episode process (2.4-4.2 s of it imports, python-control
importing pyplot included). On a machine shared with other jobs the figures
are pessimistic; the load average is printed.
"""

from __future__ import annotations

import argparse
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
STAGES = ("t_semg_s", "t_features_s", "t_estimator_s", "t_operator_s", "t_controller_s",
          "t_physics_s")
EPISODE = ["episode", "--controller", "pid", "--estimator", "ss_kf", "--object", "can"]
EPISODE_LIMIT_S = 1.5
HELP_LIMIT_S = 0.5


def episode_loop(user: str = "reacting") -> float:
    """Real-time factor of the episode loop with ``user``, printing the split by stage."""
    from scenarios.runners.episode import EpisodeSpec, run_episode
    from sim.errors import GriploopError
    from sim.hand.objects import make_object
    from sim.user.subjects import VirtualSubject

    subject = VirtualSubject.sample(0, 1)
    can = make_object("can", mass_kg=0.4, friction=0.5)
    totals = dict.fromkeys(STAGES, 0.0)
    simulated = wall = 0.0
    timed: list[int] = []
    failed: list[str] = []
    warm = False
    for seed in range(9):  # the first episode that runs warms the caches, untimed
        start = time.perf_counter()
        try:
            row = run_episode(subject, can, EpisodeSpec(estimator="ss_kf", controller="pid",
                                                        seed=seed, user=user)).row
        except GriploopError as err:  # an unstable fit, a diverged episode: say so, go on
            failed.append(f"seed {seed}: {err}")
            continue
        if not warm:
            warm = True
            continue
        wall += time.perf_counter() - start
        simulated += row["simulated_s"]
        timed.append(seed)
        for k in STAGES:
            totals[k] += row[k]
    for line in failed:
        print(f"  not timed, {line}")
    if not timed:
        print(f"{user} user: no episode ran")
        return float("nan")
    loop = sum(totals.values())
    print(f"{user} user: {len(timed)} episodes (seeds {', '.join(map(str, timed))}), "
          f"{simulated:.1f} s simulated, ss_kf free_run + PID at 100 Hz")
    for k in STAGES:
        print(f"  {k[2:-2]:<11} {totals[k] * 1e3 / len(timed):8.1f} ms/episode "
              f"({100 * totals[k] / loop:4.1f} %)")
    print(f"episode loop: {simulated / loop:6.1f}x real time (goal >= 50x)")
    print(f"whole call incl. calibration session and fit: {simulated / wall:6.1f}x real time")
    print(f"per control step: {1e6 * loop / (simulated / 0.01):.0f} us "
          f"(physics {1e6 * totals['t_physics_s'] / (simulated / 0.01):.0f} us)")
    return simulated / loop


def process_s(argv: list[str], env: dict[str, str]) -> float:
    """Wall time of one ``python argv`` process of this tree, s; NaN (said) if it failed."""
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, *argv], cwd=ROOT, env=env, capture_output=True,
                         text=True)
    elapsed = time.perf_counter() - t0
    if out.returncode != 0:
        last = out.stderr.strip().splitlines()[-1:] or ["(no output)"]
        print(f"  {shlex.join(argv)} failed ({out.returncode}): {last[0]}")
        return float("nan")
    return elapsed


def processes(repeat: int) -> dict[str, float]:
    """Best wall time of each process configuration, s."""
    with tempfile.TemporaryDirectory(prefix="bench-episode-") as cache:
        env = {**os.environ, "PYTHONPATH": str(ROOT), "GRIPLOOP_CACHE_DIR": cache,
               "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "OMP_NUM_THREADS": "1"}
        cold = process_s(["-m", "scenarios.cli", *EPISODE], env)  # fills the cache
        print(f"first episode process (cold cache: plants linearized, design made): {cold:.2f} s")
        configs = {
            "episode (warm cache)": (["-m", "scenarios.cli", *EPISODE], env),
            "episode (design cache off)": (["-m", "scenarios.cli", *EPISODE],
                                           {**env, "GRIPLOOP_DESIGN_CACHE": "off"}),
            "--help": (["-m", "scenarios.cli", "--help"], env),
            "import of the episode command": (
                ["-c", "import scenarios.cli.main, scenarios.cli.commands.episode"], env),
            "python alone": (["-c", "pass"], env),
        }
        times: dict[str, list[float]] = {k: [] for k in configs}
        for _ in range(repeat):
            for label, (argv, e) in configs.items():
                times[label].append(process_s(argv, e))
    ran = {k: [t for t in v if t == t] for k, v in times.items()}  # the runs that did not fail
    best = {k: min(v, default=float("nan")) for k, v in ran.items()}
    print(f"processes, best of {repeat} (interleaved), load average "
          f"{os.getloadavg()[0]:.2f}:")
    for label, t in best.items():
        print(f"  {label:<32} {t:6.2f} s   (median "
              f"{statistics.median(ran[label]) if ran[label] else float('nan'):.2f} s)")
    print("  command: " + shlex.join(["python", "-m", "scenarios.cli", *EPISODE]))
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs of each process")
    args = parser.parse_args()
    print("command:", shlex.join([sys.executable, *sys.argv]))
    os.environ.setdefault("MUJOCO_GL", "egl")
    med = processes(args.repeat)
    factor = episode_loop("reacting")
    scripted = episode_loop("scripted")
    goal_line("episode loop >= 50x real time", factor, "x", limit=50.0, better="higher",
              reference=f"reacting user (the default); scripted user {scripted:.1f}x; ss_kf "
              "free_run + PID at 100 Hz, the trials of seeds 1-8 that run")
    goal_line(f"griploop episode process <= {EPISODE_LIMIT_S:g} s (warm cache)",
              med["episode (warm cache)"], "s", limit=EPISODE_LIMIT_S,
              reference=f"design cache off {med['episode (design cache off)']:.2f} s; imports "
              f"{med['import of the episode command']:.2f} s; main 3.66 s")
    goal_line(f"griploop --help <= {HELP_LIMIT_S:g} s", med["--help"], "s", limit=HELP_LIMIT_S,
              reference=f"python alone {med['python alone']:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
