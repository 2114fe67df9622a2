"""MPC solve time at horizon 20: median and p99 per QP solver (target: <= 1 ms, <= 5 ms).

Runs the slip-aware MPC in closed loop on the representative grip plant
(100 N per unit command, time constants 60 and 20 ms, 10 ms period, one period
of computation delay) with a varying reference, force bounds that become
active (slip bound 5.9 N, fragility limit 12 N) and 0.2 N measurement noise.
Each solve is timed around the CasADi call; the first (setup) solve is excluded.

Run: .venv/bin/python benchmarks/bench_mpc.py
"""

from __future__ import annotations

import platform
import sys
import time

import control
import numpy as np

from controllers import MPC, force_bounds

N_STEPS = 2000
TARGET_MEDIAN_MS = 1.0
TARGET_P99_MS = 5.0


def run(solver: str) -> dict[str, float]:
    s = control.tf("s")
    plant = control.c2d(100.0 / ((0.06 * s + 1) * (0.02 * s + 1)), 0.01)
    mpc = MPC(plant, horizon=20, solver=solver,
              force_bounds=force_bounds(0.4, 0.5, fragility_limit_n=12.0))
    ss = control.ss(plant)
    a, b, c = (np.asarray(m) for m in (ss.A, ss.B, ss.C))
    rng = np.random.default_rng(0)
    x = np.zeros(a.shape[0])
    pending = 0.0
    start = time.perf_counter()
    for k in range(N_STEPS):
        ref = 8.0 + 6.0 * np.sin(2 * np.pi * 0.5 * k * 0.01) + (4.0 if (k // 300) % 2 else 0.0)
        y = (c @ x).item() + 0.2 * rng.standard_normal()
        u = mpc.act({"time_s": k * 0.01, "reference_n": ref, "grip_force_n": y})
        x = a @ x + b.ravel() * pending
        pending = u
    wall = time.perf_counter() - start
    t_ms = np.asarray(mpc.stats_.solve_times_s[1:]) * 1e3
    return {"median_ms": float(np.median(t_ms)), "p99_ms": float(np.percentile(t_ms, 99)),
            "max_ms": float(t_ms.max()), "failures": mpc.stats_.n_failures,
            "softened": mpc.stats_.n_softened, "act_us": wall / N_STEPS * 1e6}


def main() -> int:
    print(f"command: {sys.executable} {' '.join(sys.argv)}")
    print(f"machine: {platform.machine()} {platform.processor() or ''} python "
          f"{platform.python_version()}")
    print(f"MPC horizon 20, {N_STEPS} closed-loop steps; targets median <= {TARGET_MEDIAN_MS} ms, "
          f"p99 <= {TARGET_P99_MS} ms")
    print(f"{'solver':8s} {'median ms':>10s} {'p99 ms':>8s} {'max ms':>8s} {'act us':>8s} "
          f"{'failed':>7s} {'softened':>9s}  verdict")
    ok = True
    for solver in ("osqp", "proxqp", "qrqp"):
        r = run(solver)
        meets = r["median_ms"] <= TARGET_MEDIAN_MS and r["p99_ms"] <= TARGET_P99_MS
        verdict = "meets target" if meets and not r["failures"] else (
            "FAILS" + (f" ({r['failures']} failed solves)" if r["failures"] else ""))
        if solver == "osqp":  # the default solver carries the target
            ok = ok and meets and not r["failures"]
        print(f"{solver:8s} {r['median_ms']:10.3f} {r['p99_ms']:8.3f} {r['max_ms']:8.2f} "
              f"{r['act_us']:8.0f} {r['failures']:7d} {r['softened']:9d}  {verdict}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
