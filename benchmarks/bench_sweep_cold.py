"""A first sweep on a new machine: 36 episodes from an empty cache, on 1, 2 and 4 workers.

Goal (issue 22): the 2-worker sweep at least 1.8x as fast as the 1-worker one,
each from an empty cache of its own (no plant family linearized, no controller
designed), as the first sweep a user runs is.

The sweep: the can over 4 masses x 3 frictions x PID / lead-lag / MPC with the
oracle reference (12 objects, so 12 plant families and 36 designs to build).
Each run is a whole ``griploop sweep`` process (imports included) with its
own empty ``GRIPLOOP_CACHE_DIR`` and store; the configurations are run
interleaved, ``--repeat`` times, and the median and the range are printed.

What makes it scale: the driver hands each worker the scenarios of the object
it holds (:func:`scenarios.execution.workers.design_group`), so distinct
objects' families and designs are built in parallel; a worker that misses an
entry another worker is building waits for its file (:func:`sim.cache.build_lock`)
instead of building it too; and with several workers each uses one BLAS
thread, so they do not oversubscribe the cores.

On a 2-core machine, 4 workers measure oversubscription (more processes than
cores), not scaling. The load average is printed before each run: timings
taken while other jobs run are pessimistic.

Run::

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_sweep_cold.py [--repeat 3] [--workers 1,2,4]
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

SWEEP = """\
name: cold36
seed: 3
base:
  kind: episode
  object: {name: can}
  estimator: {name: oracle, mode: free_run}
  controller: {kind: pid}
grid:
  object.mass_kg: [0.2, 0.4, 0.6, 0.8]
  object.friction: [0.4, 0.7, 1.0]
  controller.kind: [pid, lead_lag, mpc]
"""


def run_cold(workers: int, root: Path, index: int) -> float:
    """Wall time of one ``griploop sweep`` process from an empty cache, s."""
    run = root / f"w{workers}-{index}"
    run.mkdir()
    sweep = run / "cold36.yaml"
    sweep.write_text(SWEEP)
    griploop = Path(sys.executable).with_name("griploop")
    cmd = [str(griploop), "sweep", str(sweep), "--workers", str(workers),
           "--db", str(run / "results.sqlite"), "--no-progress"]
    env = {**os.environ, "GRIPLOOP_CACHE_DIR": str(run / "cache"),
           "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    elapsed = time.perf_counter() - t0
    if done.returncode != 0 or " 36 ok, 0 failed" not in done.stdout:
        raise SystemExit(f"{shlex.join(cmd)} failed: {done.stdout}{done.stderr}")
    return elapsed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--workers", default="1,2,4",
                        help="worker counts, comma-separated (default 1,2,4)")
    args = parser.parse_args(argv)
    counts = [int(w) for w in args.workers.split(",")]
    print(f"command: {shlex.join([sys.executable, *sys.argv])}")
    print(f"cores: {os.cpu_count()}; each run: griploop sweep (36 cold episodes) in a new "
          "process, empty cache")
    times: dict[int, list[float]] = {w: [] for w in counts}
    with tempfile.TemporaryDirectory(prefix="griploop-cold-") as tmp:
        for i in range(args.repeat):
            for w in counts:
                load = os.getloadavg()[0]
                times[w].append(run_cold(w, Path(tmp), i))
                print(f"run {i + 1}: {w} worker(s) {times[w][-1]:6.1f} s "
                      f"(load average before: {load:.2f})", flush=True)
    for w in counts:
        t = times[w]
        note = "  (more workers than cores: oversubscription)" if w > (os.cpu_count() or 1) else ""
        print(f"{w} worker(s): median {statistics.median(t):.1f} s, range "
              f"{min(t):.1f}-{max(t):.1f} s over {len(t)} runs{note}")
    if 1 in times and 2 in times:
        one, two = statistics.median(times[1]), statistics.median(times[2])
        goal_line("cold 36-episode sweep, 2 workers vs 1 >= 1.8x", one / two, "x", limit=1.8,
                  better="higher", reference=f"1 worker {one:.1f} s, 2 workers {two:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
