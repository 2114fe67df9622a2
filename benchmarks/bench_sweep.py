"""Sweep speed and memory on real episodes: 1 vs 2 workers, against main's executor.

Goals:

1. scaling from 1 to 2 workers >= 1.8x on the same sweep (wall time of
   :func:`scenarios.execution.sweep.run_sweep`, the driver's whole job);
2. scenarios per minute per worker, at 2 workers, >= 2x main's executor
   measured in the same run;
3. a 2-worker sweep uses < 600 MB for its whole process tree (driver and
   workers), peak proportional set size (PSS: a page shared by n processes
   counts 1/n in each, so the sum is the memory the tree really holds; the
   plain RSS sum, which counts pages shared after fork once per process, is
   printed next to it).

The sweep is ``scenarios/library/demo.yaml`` (54 closed-loop episodes: can over
mass x friction, PID / lead-lag / MPC, oracle and free-run MLP reference), or
its first ``--scenarios`` scenarios.

**Main's executor, the reference.** Before the forked workers, a sweep of more than one
worker started a dask ``LocalCluster`` (one process per worker plus a nanny
each and a scheduler), each worker imported griploop itself and forked its
sandbox from there, and every worker designed every controller it met (only
plant families were cached on disk). The reference here runs exactly that
path of today's code: a ``LocalCluster`` started by this script and given to
:func:`run_sweep` as a scheduler address (the dask path is unchanged), with
``GRIPLOOP_DESIGN_CACHE=off``; the cluster's start and shutdown are counted in
its wall time, as ``griploop sweep --workers 2`` on main paid them. Measured on
main itself before the change (same 54 episodes, warm plant cache, loaded
machine): 1 worker 34.3 s, 2 workers 27.6 s (1.24x; 58.7 scenarios/min/worker);
2 workers held 811-838 MB RSS.

**Ours.** ``run_sweep(planned, store, SweepExecution(workers=n))`` forks ``n`` sandbox
children from the driver (already importing griploop) and reuses designs from the disk cache
(:mod:`controllers.design_cache`). All runs share one fresh cache directory; a
first, untimed-for-goals pass fills it (its time is printed as "cold": plant
families linearized and designs made once, as a first sweep on a new machine
pays), then the configurations are timed interleaved, ``--repeat`` times each
(median reported). Each timed run writes to a new store, so every scenario
runs.

Timings need two free cores: on a machine shared with other jobs the 2-worker
figures are pessimistic. The load average and the CPU time of the workers are
printed so a loaded run can be recognized.

Run::

    MUJOCO_GL=egl .venv/bin/python benchmarks/bench_sweep.py [--scenarios 54] [--repeat 1]
"""

from __future__ import annotations

import argparse
import logging
import os
import shlex
import statistics
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from _timing import goal_line

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "scenarios" / "library" / "demo.yaml"
MEMORY_LIMIT_MB = 600.0


# ------------------------------------------------------------------ memory of a process tree
def _children() -> dict[int, list[int]]:
    tree: dict[int, list[int]] = {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            with open(f"/proc/{entry.name}/stat") as fh:
                ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        tree.setdefault(ppid, []).append(int(entry.name))
    return tree


def tree_pids(root: int) -> list[int]:
    """``root`` and every descendant process."""
    tree, out, todo = _children(), [], [root]
    while todo:
        pid = todo.pop()
        out.append(pid)
        todo.extend(tree.get(pid, ()))
    return out


def memory_mb(pid: int) -> tuple[float, float]:
    """``(rss, pss)`` of one process, MB (0 if it is gone)."""
    rss = pss = 0.0
    try:
        with open(f"/proc/{pid}/smaps_rollup") as fh:
            for line in fh:
                if line.startswith("Rss:"):
                    rss = float(line.split()[1]) / 1024
                elif line.startswith("Pss:"):
                    pss = float(line.split()[1]) / 1024
    except OSError:
        pass
    return rss, pss


class TreeMemory:
    """Peak RSS sum and PSS sum of this process's tree, sampled every ``interval_s``."""

    def __init__(self, interval_s: float = 0.2) -> None:
        self.interval_s = interval_s
        self.peak_rss_mb = self.peak_pss_mb = 0.0
        self.max_processes = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.is_set():
            pids = tree_pids(os.getpid())
            samples = [memory_mb(p) for p in pids]
            self.peak_rss_mb = max(self.peak_rss_mb, sum(r for r, _ in samples))
            self.peak_pss_mb = max(self.peak_pss_mb, sum(p for _, p in samples))
            self.max_processes = max(self.max_processes, len(pids))
            self._stop.wait(self.interval_s)

    def __enter__(self) -> TreeMemory:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


# ------------------------------------------------------------------ one timed sweep
def children_cpu_s() -> float:
    """CPU time (user + system) of this process's finished children, s."""
    t = os.times()
    return t.children_user + t.children_system


@contextmanager
def main_executor(workers: int):
    """A dask LocalCluster as `griploop sweep --workers n` started on main, no design cache."""
    from distributed import LocalCluster

    os.environ["GRIPLOOP_DESIGN_CACHE"] = "off"  # inherited by the cluster's processes only
    try:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR)
    finally:
        del os.environ["GRIPLOOP_DESIGN_CACHE"]
    with cluster:
        yield cluster.scheduler_address


def timed_sweep(planned, tmp: Path, label: str, workers: int, reference: bool) -> dict:
    """Run the sweep into a new store; wall time, peak memory and worker CPU time."""
    from scenarios.execution.sweep import SweepExecution, run_sweep
    from scenarios.store import ResultStore

    db = tmp / f"{label}-{time.monotonic_ns()}.sqlite"
    cpu0 = children_cpu_s()
    with TreeMemory() as mem:
        t0 = time.perf_counter()
        with ResultStore(db) as store:
            if reference:
                with main_executor(workers) as address:
                    summary = run_sweep(planned, store, SweepExecution(scheduler=address),
                                        progress=False)
            else:
                summary = run_sweep(planned, store, SweepExecution(workers=workers),
                                    progress=False)
            busy_s = sum(r["duration_s"] for r in store.rows())
        wall = time.perf_counter() - t0
    if summary.ok + summary.failed != len(planned) or summary.failed:
        raise SystemExit(f"{label}: expected {len(planned)} ok scenarios, found {summary}")
    return {"wall_s": wall, "rate": 60 * len(planned) / wall / workers,
            "rss_mb": mem.peak_rss_mb, "pss_mb": mem.peak_pss_mb,
            "processes": mem.max_processes, "busy_s": busy_s,
            "cpu_s": children_cpu_s() - cpu0}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sweep", type=Path, default=DEMO, help="sweep file (default: demo)")
    parser.add_argument("--scenarios", type=int, default=None,
                        help="run only the first N scenarios of the sweep")
    parser.add_argument("--repeat", type=int, default=1, help="timed runs per configuration")
    parser.add_argument("--no-reference", action="store_true",
                        help="skip main's executor (dask LocalCluster, no design cache)")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    print("command:", shlex.join([sys.executable, *sys.argv]))

    from scenarios.execution.sweep import plan
    from scenarios.schema import expand_sweep, load_sweep

    spec = load_sweep(args.sweep)
    planned = plan(expand_sweep(spec))[: args.scenarios]
    n = len(planned)
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as name:
        tmp = Path(name)
        os.environ["GRIPLOOP_CACHE_DIR"] = str(tmp / "cache")
        print(f"sweep: {args.sweep.name}, {n} scenarios; {os.cpu_count()} CPUs, "
              f"load average {os.getloadavg()[0]:.2f}; cache {tmp / 'cache'} (fresh)")
        cold = timed_sweep(planned, tmp, "cold", 2, reference=False)
        print(f"cold (plants and designs built once, 2 workers): {cold['wall_s']:.1f} s")
        configs = [("ours, 1 worker", 1, False), ("ours, 2 workers", 2, False)]
        if not args.no_reference:
            configs.insert(0, ("main's executor, 2 workers", 2, True))
        runs: dict[str, list[dict]] = {label: [] for label, _, _ in configs}
        for _ in range(args.repeat):
            for label, workers, reference in configs:
                runs[label].append(timed_sweep(planned, tmp, label.split(",")[0][:4], workers,
                                               reference))
        print(f"load average after: {os.getloadavg()[0]:.2f}")
        med = {label: {k: statistics.median(r[k] for r in rs) for k in rs[0]}
               for label, rs in runs.items()}
        print(f"{'configuration':<28} {'wall s':>7} {'/min/worker':>12} {'PSS MB':>7} "
              f"{'RSS MB':>7} {'procs':>5} {'task s':>7} {'CPU s':>7}")
        for label, m in med.items():
            print(f"{label:<28} {m['wall_s']:7.1f} {m['rate']:12.1f} {m['pss_mb']:7.0f} "
                  f"{m['rss_mb']:7.0f} {m['processes']:5.0f} {m['busy_s']:7.1f} "
                  f"{m['cpu_s']:7.1f}")
        print("(task s: summed scenario durations; CPU s: user+system of the finished child "
              "processes; a 2-worker task s far above 1 worker's means the cores were busy)")
    one, two = med["ours, 1 worker"], med["ours, 2 workers"]
    scaling = one["wall_s"] / two["wall_s"]
    goal_line("sweep scaling 1 -> 2 workers >= 1.8x", scaling, "x", limit=1.8, better="higher",
              reference=f"{n} episodes: 1 worker {one['wall_s']:.1f} s, "
              f"2 workers {two['wall_s']:.1f} s")
    if not args.no_reference:
        ref = med["main's executor, 2 workers"]
        goal_line("scenarios/min/worker at 2 workers >= 2x main's executor",
                  two["rate"] / ref["rate"], "x", limit=2.0, better="higher",
                  reference=f"main's executor {ref['rate']:.1f}/min/worker, "
                  f"ours {two['rate']:.1f}/min/worker")
    main_label = "main's executor, 2 workers"
    memory_ref = f"RSS sum {two['rss_mb']:.0f} MB"
    if main_label in med:
        memory_ref += f"; main's executor: PSS {med[main_label]['pss_mb']:.0f} MB"
    goal_line(f"2-worker sweep memory, process tree peak PSS < {MEMORY_LIMIT_MB:g} MB",
              two["pss_mb"], "MB", limit=MEMORY_LIMIT_MB, reference=memory_ref)
    return 0


if __name__ == "__main__":
    sys.exit(main())
