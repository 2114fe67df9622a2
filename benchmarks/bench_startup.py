"""Start-up of one ``griploop episode`` process on cached designs (issue 22, item 4).

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_startup.py [--repeat 3] [--base DIR]``

Goal: ``griploop episode --controller pid --estimator oracle --object can --seed 0``
takes at most 1.2 s of wall time with a warm cache (the can's plant family and PID
design on disk from an earlier run): the median of ``--repeat`` runs after one untimed
warm-up run, with the spread (min-max) beside it.

Each process is ``python -m scenarios.cli`` of this tree (``PYTHONPATH``), the path of
the console script (:func:`scenarios.cli.main.entry`), in a fresh cache directory of its
own. Printed next to it from the same run: the import of the episode command alone
(``-X importtime`` of this tree, what no cache can save, with the packages that cost the
most) and python alone. ``--base DIR`` times another source tree the same way,
interleaved run by run with this one (e.g. ``git archive`` of the commit before a
change), so that both see the same load. This machine is shared with other jobs: the
load average is printed, and CPU time (user + system, less sensitive to other jobs than
wall time) is given next to every wall time.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
EPISODE = ["episode", "--controller", "pid", "--estimator", "oracle", "--object", "can",
           "--seed", "0"]
IMPORTS = ("from scenarios.cli.deferred import defer_plotting; defer_plotting(); "
           "import scenarios.cli.main, scenarios.cli.commands.episode")
LIMIT_S = 1.2


def run_s(argv: list[str], tree: Path, cache: str) -> tuple[float, float]:
    """Wall and CPU (user + system) time of one ``python argv`` process of ``tree``, s."""
    env = {**os.environ, "PYTHONPATH": str(tree), "GRIPLOOP_CACHE_DIR": cache,
           "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl"), "MPLBACKEND": "Agg"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, *argv], cwd=tree, env=env, capture_output=True,
                         text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        raise SystemExit(f"{shlex.join(argv)} in {tree} failed ({out.returncode}):\n"
                         f"{out.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def summary(times: list[tuple[float, float]]) -> dict[str, float]:
    """Median, min and max of the wall times, and the median CPU time."""
    walls = [w for w, _ in times]
    return {"median": statistics.median(walls), "min": min(walls), "max": max(walls),
            "cpu": statistics.median(c for _, c in times)}


def fmt(s: dict[str, float]) -> str:
    return (f"{s['median']:.2f} s (spread {s['min']:.2f}-{s['max']:.2f} s; CPU "
            f"{s['cpu']:.2f} s)")


def heaviest_imports(tree: Path, n: int = 8) -> list[tuple[str, float]]:
    """Top-level packages by their own import time in ``tree``'s episode command, ms."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    out = subprocess.run([sys.executable, "-X", "importtime", "-c", IMPORTS], cwd=tree,
                         env=env, capture_output=True, text=True)
    own: Counter[str] = Counter()
    for line in out.stderr.splitlines():
        m = re.match(r"import time:\s+(\d+) \|\s+\d+ \|\s*(\S+)", line)
        if m:
            own[m.group(2).split(".")[0]] += int(m.group(1)) / 1000.0
    return own.most_common(n)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs of each (default 3)")
    parser.add_argument("--base", type=Path, default=None, metavar="DIR",
                        help="also time this source tree, interleaved with this one")
    args = parser.parse_args()
    trees = {"this tree": ROOT, **({"base": args.base.resolve()} if args.base else {})}
    print("command:", shlex.join(["griploop", *EPISODE]), f"(median of {args.repeat} after "
          "one warm-up run; warm cache)")
    print(f"load average before: {os.getloadavg()[0]:.2f} (2 cores shared with other jobs "
          "make every figure pessimistic)")
    with tempfile.TemporaryDirectory(prefix="bench-startup-") as tmp:
        caches = {label: str(Path(tmp) / label.replace(" ", "-")) for label in trees}
        for label, tree in trees.items():  # warm-up: linearize the plants, make the design
            cold = run_s(["-m", "scenarios.cli", *EPISODE], tree, caches[label])
            print(f"{label}: warm-up (cold cache) {cold[0]:.2f} s")
        episode: dict[str, list[tuple[float, float]]] = {k: [] for k in trees}
        imports: dict[str, list[tuple[float, float]]] = {k: [] for k in trees}
        bare: list[tuple[float, float]] = []
        for _ in range(args.repeat):
            for label, tree in trees.items():
                episode[label].append(run_s(["-m", "scenarios.cli", *EPISODE], tree,
                                            caches[label]))
                imports[label].append(run_s(["-c", IMPORTS], tree, caches[label]))
            bare.append(run_s(["-c", "pass"], ROOT, caches["this tree"]))
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    for label, tree in trees.items():
        print(f"{label} ({tree}):")
        print(f"  episode process        {fmt(summary(episode[label]))}")
        print(f"  imports of the command {fmt(summary(imports[label]))}")
        print("  heaviest imports (own time, ms): " + ", ".join(
            f"{name} {ms:.0f}" for name, ms in heaviest_imports(tree)))
    print(f"python alone             {fmt(summary(bare))}")
    ours = summary(episode["this tree"])
    reference = f"imports {summary(imports['this tree'])['median']:.2f} s; python alone " \
                f"{summary(bare)['median']:.2f} s; spread {ours['min']:.2f}-{ours['max']:.2f} s"
    if "base" in trees:
        reference += f"; base tree {summary(episode['base'])['median']:.2f} s"
    goal_line(f"griploop episode start-up <= {LIMIT_S:g} s (warm cache, median of "
              f"{args.repeat})", ours["median"], "s", limit=LIMIT_S, reference=reference)
    return 0


if __name__ == "__main__":
    sys.exit(main())
