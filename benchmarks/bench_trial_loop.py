"""The one trial loop's cost against another source tree, interleaved (issue 33, "Speed").

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_trial_loop.py --base DIR [--pairs 5]``
(``DIR``: e.g. ``git archive`` of the commit before a change, unpacked).

Goals: an episode and a practised trial of this tree cost at most 5 % more wall time per
simulated second than the same trials of the base tree, each the median over
``--pairs`` interleaved pairs of child processes (which tree goes first alternating), on
the same machine and load:

- **episode**: a novice's grasp-lift-hold of the can (ss_kf free run, PID), seeds 0-3,
  calibration and design warm (the whole :func:`~scenarios.runners.episode.run_episode`
  after one warm-up episode);
- **practised trial**: issue 20's episode (latent_kf, PID, subject 1, seed 1) by the user
  after five practice lifts, practice cached on disk (each tree its own warm cache);
- **scripted episode** (printed, not a goal): the scripted user's 6 s episode, which
  this tree runs through the one loop and the base tree, before issue 33, on its batch
  path.

Each child process is ``python -c`` with ``PYTHONPATH`` the tree, and calls the tree's
own ``run_episode`` (either signature: the ``EpisodeSpec`` of this tree or the keywords
of earlier ones). Without ``--base`` only this tree's times are printed.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
LIMIT = 1.05

CHILD = r"""
import json, sys, time
from sim.hand.objects import make_object
from sim.user.subjects import VirtualSubject
import scenarios.runners.episode as E

case, warm = sys.argv[1], sys.argv[2] == "warm"

def episode(subject, obj, **kw):
    if hasattr(E, "EpisodeSpec"):
        return E.run_episode(subject, obj, E.EpisodeSpec(**kw))
    return E.run_episode(subject, obj, **kw)

can = make_object("can", mass_kg=0.4, friction=0.5)
if case == "episode":
    runs = [(VirtualSubject.sample(0, 1), can, dict(estimator="ss_kf", controller="pid",
                                                     seed=s, practice=0)) for s in range(4)]
elif case == "practised":
    runs = [(VirtualSubject.sample(0, 1), make_object("can"),
             dict(estimator="latent_kf", controller="pid", seed=1))] * 3
else:
    runs = [(VirtualSubject.sample(0, 1), can, dict(estimator="ss_kf", controller="pid",
                                                     seed=s, user="scripted"))
            for s in range(4)]
episode(*runs[0][:2], **runs[0][2])  # warm: design, calibration, practice
if warm:
    sys.exit(0)
wall = cpu = sim = 0.0
for subject, obj, kw in runs:
    t0, c0 = time.perf_counter(), time.process_time()
    row = episode(subject, obj, **kw).row
    wall += time.perf_counter() - t0
    cpu += time.process_time() - c0
    sim += row["simulated_s"]
print(json.dumps({"per_s": wall / sim, "cpu_per_s": cpu / sim}))
"""

CASES = ("episode", "practised", "scripted")


def child(tree: Path, cache: str, case: str, warm: bool = False) -> dict[str, float] | None:
    """Wall and CPU time per simulated second of ``case`` in a child process of ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree), "GRIPLOOP_CACHE_DIR": cache,
           "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "MPLBACKEND": "Agg"}
    out = subprocess.run([sys.executable, "-c", CHILD, case, "warm" if warm else "time"],
                         cwd=tree, env=env, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{case} in {tree} failed:\n{out.stderr}")
    return None if warm else json.loads(out.stdout.strip().splitlines()[-1])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", type=Path, default=None, metavar="DIR",
                        help="the source tree to compare with, interleaved")
    parser.add_argument("--pairs", type=int, default=5, help="interleaved pairs (default 5)")
    args = parser.parse_args()
    trees = {"this tree": ROOT, **({"base": args.base.resolve()} if args.base else {})}
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory(prefix="bench-trial-loop-") as tmp:
        caches = {label: str(Path(tmp) / label.replace(" ", "-")) for label in trees}
        for label, tree in trees.items():
            for case in CASES:
                child(tree, caches[label], case, warm=True)
        times = {(label, case): [] for label in trees for case in CASES}
        for i in range(args.pairs):
            order = list(trees.items()) if i % 2 == 0 else list(reversed(trees.items()))
            for case in CASES:
                for label, tree in order:
                    times[label, case].append(child(tree, caches[label], case))
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    def median(label: str, case: str, key: str = "per_s") -> float:
        return statistics.median(t[key] for t in times[label, case])

    for case in CASES:
        line = ", ".join(f"{label} {1e3 * median(label, case):.1f} ms (CPU "
                         f"{1e3 * median(label, case, 'cpu_per_s'):.1f} ms)" for label in trees)
        print(f"{case:<10} wall time per simulated second (median of {args.pairs}): {line}")
    if "base" not in trees:
        return 0

    def ratios(case: str, key: str) -> list[float]:
        return [a[key] / b[key] for a, b in zip(times["this tree", case], times["base", case],
                                                strict=True)]

    for case, goal in (("episode", "an episode"), ("practised", "a practised trial")):
        wall, cpu = ratios(case, "per_s"), ratios(case, "cpu_per_s")
        goal_line(f"{goal} costs <= {LIMIT:g} x the base tree's (interleaved, median of "
                  f"{args.pairs} pairs)", statistics.median(wall), "x", limit=LIMIT,
                  reference=f"base {1e3 * median('base', case):.1f} ms per simulated s; pairs "
                  f"{min(wall):.3f}-{max(wall):.3f}; CPU-time ratio "
                  f"{statistics.median(cpu):.3f}")
    print(f"scripted episode (not a goal: the base tree's batch path): wall "
          f"{statistics.median(ratios('scripted', 'per_s')):.3f} x, CPU "
          f"{statistics.median(ratios('scripted', 'cpu_per_s')):.3f} x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
