"""Sweep engine speed: throughput on 1 vs 2 workers, and store overhead per result.

Goals (griploop issue 6): throughput scaling 1 -> 2 workers >= 1.7x on the same
sweep; store overhead under 5 ms per result.

The sweep runs a CPU-bound pure-Python task of about ``--task-ms`` per
scenario (single-threaded, so no BLAS threads blur the scaling). One worker
runs in-process; two workers run on a dask LocalCluster (processes, one thread
each), whose start-up is timed separately and reported apart, since a long
sweep pays it once.

Run::

    .venv/bin/python benchmarks/bench_sweep.py [--scenarios 40] [--task-ms 250]
"""

from __future__ import annotations

import argparse
import logging
import os
import shlex
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from scenarios.execution.sweep import plan, run_sweep
from scenarios.schema import Scenario, expand_sweep, parse_sweep
from scenarios.store import Outcome, ResultStore, content_hash, encode_traces

_LOOPS = 200_000  # rounds of spin(); set by calibrate(), shipped to workers with spin


def spin(scenario: Scenario) -> dict:
    """CPU-bound task: ``_LOOPS`` rounds of integer arithmetic seeded by the scenario."""
    acc = scenario.seed % 1000
    for i in range(_LOOPS):
        acc = (acc * 1103515245 + i) % 2147483648
    return {"acc": acc}


def calibrate(task_ms: float) -> int:
    """Rounds of :func:`spin` that take about ``task_ms`` on this machine."""
    best_s = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        spin(Scenario(seed=1))
        best_s = min(best_s, time.perf_counter() - t0)
    return max(1, int(_LOOPS / (best_s * 1e3) * task_ms))


def sweep_items(n: int):
    spec = parse_sweep({"name": "bench", "seed": 1, "replicates": n, "base": {}})
    return plan(expand_sweep(spec), spin, version="bench")


def throughput(n: int, workers: int, tmp: Path) -> tuple[float, float]:
    """Wall time of the sweep and mean wall time of one task on its worker, s."""
    with ResultStore(tmp / f"w{workers}.sqlite") as store:
        summary = run_sweep(sweep_items(n), store, task=spin, workers=workers,
                            progress=False, version="bench")
        task_s = float(np.mean([r["duration_s"] for r in store.rows()]))
    assert summary.ok == n, summary
    return summary.elapsed_s, task_s


def cluster_startup_s() -> float:
    from distributed import Client, LocalCluster

    t0 = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR) as cluster:
        with Client(cluster) as client:
            client.wait_for_workers(2)
            elapsed = time.perf_counter() - t0
    return elapsed


def store_overhead_ms(n: int, tmp: Path, trace_samples: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    blob = encode_traces({"force_n": rng.standard_normal((trace_samples, 3))}) \
        if trace_samples else None
    config = Scenario(seed=0).canonical_json()
    times = np.empty(n)
    with ResultStore(tmp / f"store{trace_samples}.sqlite") as store:
        for i in range(n):
            out = Outcome(hash=content_hash(config, str(i), "bench"), status="ok",
                          result={"r2": float(rng.random()), "nrmse": 0.5, "slips": 2,
                                  "estimator": "ss_kf"},
                          traces=blob, error=None, traceback=None, started_at=0.0,
                          finished_at=1.0, duration_s=1.0, worker="bench:0")
            t0 = time.perf_counter()
            store.record(out, kind="episode", config_json=config, task="bench", version="b")
            times[i] = time.perf_counter() - t0
    return times * 1e3


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=int, default=40)
    parser.add_argument("--task-ms", type=int, default=250)
    parser.add_argument("--store-rows", type=int, default=500)
    args = parser.parse_args()
    global _LOOPS
    _LOOPS = calibrate(args.task_ms)
    print("command:", shlex.join([sys.executable, *sys.argv]))
    print(f"sweep: {args.scenarios} scenarios of ~{args.task_ms} ms CPU each; "
          f"{os.cpu_count()} CPUs, load average before {os.getloadavg()[0]:.2f}")
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        startup = cluster_startup_s()
        t1, task1 = throughput(args.scenarios, 1, tmp)
        t2, task2 = throughput(args.scenarios, 2, tmp)
        rate1 = 60 * args.scenarios / t1
        rate2 = 60 * args.scenarios / t2
        rate2_warm = 60 * args.scenarios / max(t2 - startup, 1e-9)
        print(f"1 worker (in-process):      {t1:6.2f} s  {rate1:7.1f} scenarios/min")
        print(f"2 workers (dask, all-in):   {t2:6.2f} s  {rate2:7.1f} scenarios/min  "
              f"scaling {rate2 / rate1:.2f}x")
        print(f"dask LocalCluster start-up: {startup:6.2f} s (measured alone)")
        print(f"2 workers minus start-up:   {t2 - startup:6.2f} s  {rate2_warm:7.1f} "
              f"scenarios/min  scaling {rate2_warm / rate1:.2f}x  (goal >= 1.7x)")
        print(f"mean task time: {task1 * 1e3:.0f} ms on 1 worker, {task2 * 1e3:.0f} ms on 2 "
              "(a rise means the two workers did not get two free cores)")
        print(f"load average after the sweeps: {os.getloadavg()[0]:.2f}")
        for samples in (0, 3000):
            ms = store_overhead_ms(args.store_rows, tmp, samples)
            label = f"with a {samples}x3 trace" if samples else "scalars only"
            print(f"store.record ({label}): median {np.median(ms):.3f} ms, "
                  f"p95 {np.percentile(ms, 95):.3f} ms, mean {ms.mean():.3f} ms over "
                  f"{ms.size} results (goal < 5 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
