"""Speed of the paper's SS_KF estimator against the paper's Table 3.

Prints, for one virtual subject's calibration session (first 50 % of windows):

- training time (RLS identification at n = 4 plus Kalman design), median;
- streaming step time per update in a Python loop, median;
- batch prediction throughput (updates per second);

each next to the paper's figure and the ratio; then, for every registered
estimator on all 8 channels (24 inputs), training time (goal < 2 s) and the
median streaming step (goal < 20 us for the tree model ``gbt``), with SS_KF's
step measured in the same run as the reference. Run with::

    .venv/bin/python benchmarks/bench_estimation.py [--repeats 200]

BLAS is limited to one thread: the matrices are tiny and threads only add noise.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits

from estimation.features import extract_features
from estimation.kalman import design_kalman
from estimation.paper import TABLE3
from estimation.registry import ESTIMATOR_NAMES, make_estimator
from estimation.rls import rls
from estimation.state_space import identification_rows
from sim.user.subjects import make_population


def median_time(fn, repeats: int) -> float:
    """Median wall time of ``fn()`` in seconds over ``repeats`` calls (after 3 warm-ups)."""
    for _ in range(3):
        fn()
    times = np.empty(repeats)
    for i in range(repeats):
        t0 = time.perf_counter()
        fn()
        times[i] = time.perf_counter() - t0
    return float(np.median(times))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200, help="timed repetitions")
    args = parser.parse_args(argv)
    print("command:", " ".join([sys.executable.split("/")[-1], *sys.argv]))
    print(f"machine: {platform.machine()}, python {platform.python_version()}, "
          f"numpy {np.__version__}")
    subject = make_population(n=1, seed=0)[0]
    fs = extract_features(subject.paper_session(rng=np.random.default_rng(0)))
    n_id = fs.n_windows // 2
    X_id, y_id = fs.X[:n_id], fs.y[:n_id]
    print(f"data: virtual subject 1, {fs.n_windows} windows, identification {n_id} windows, "
          f"9 inputs, order 4")
    rows = []
    with threadpool_limits(limits=1, user_api="blas"):
        train = median_time(lambda: make_estimator("ss_kf", order=4).fit(X_id, y_id),
                            args.repeats)
        pipe = make_estimator("ss_kf", order=4).fit(X_id, y_id)
        est = pipe.estimator
        U_n = pipe.scaling_.transform_u(X_id)
        Phi, Xs = identification_rows(U_n, pipe.scaling_.transform_y(y_id), 4, fs.dt_s)
        t_rls = median_time(lambda: rls(Phi, Xs), args.repeats)
        t_dare = {m: median_time(lambda m=m: design_kalman(est.A_, est.C_, est.Q_, est.R_,
                                                            method=m), args.repeats)
                  for m in ("scipy", "control")}

        stream = pipe.streaming("one_step")
        rng = np.random.default_rng(1)
        n_steps = 20_000
        U = fs.X[rng.integers(0, fs.n_windows, n_steps)]
        Y = fs.y[rng.integers(0, fs.n_windows, n_steps)]
        step = stream.step
        stream.reset()
        step(U[0])
        chunk = 100
        per_update = []
        for start in range(1, n_steps - chunk, chunk):
            t0 = time.perf_counter()
            for k in range(start, start + chunk):
                step(U[k], Y[k - 1])
            per_update.append((time.perf_counter() - t0) / chunk)
        step_s = float(np.median(per_update))

        n_batch = 1_000_000
        U_big = fs.X[rng.integers(0, fs.n_windows, n_batch)]
        Y_big = fs.y[rng.integers(0, fs.n_windows, n_batch)]
        t_batch = median_time(lambda: pipe.predict(U_big, Y_big, mode="one_step"), 5)
    paper = TABLE3["ss_kf"]
    rows.append(("training (RLS + Kalman), ms", train * 1e3, paper["train_ms"][0], 2.0))
    rows.append(("streaming step, us/update", step_s * 1e6, paper["loop_ms"][0] * 1e3, 2.0))
    print(f"\n{'quantity':34s}{'ours':>12s}{'paper':>12s}{'paper/ours':>12s}{'goal':>8s}")
    for label, ours, ref, goal in rows:
        flag = "ok" if ours <= goal else "MISSED"
        print(f"{label:34s}{ours:>12.4f}{ref:>12.4f}{ref / ours:>12.1f}{'<=' + str(goal):>8s} "
              f"{flag}")
    rate = n_batch / t_batch
    print(f"{'batch prediction, updates/s':34s}{rate:>12.3g}{'-':>12s}{'-':>12s}{'>=1e6':>8s} "
          f"{'ok' if rate >= 1e6 else 'MISSED'}")
    print(f"\nparts of training: RLS {t_rls * 1e3:.3f} ms; Kalman design scipy "
          f"{t_dare['scipy'] * 1e3:.3f} ms, control.dlqe {t_dare['control'] * 1e3:.3f} ms")
    print(f"streaming step per-chunk spread: p10 {np.percentile(per_update, 10) * 1e6:.3f} us, "
          f"p90 {np.percentile(per_update, 90) * 1e6:.3f} us")
    every_estimator(subject, max(args.repeats // 20, 3))
    return 0


def stream_step_us(pipe: object, X: np.ndarray, y: np.ndarray, mode: str) -> float:
    """Median per-update time of a stream over chunks of 100 updates, microseconds."""
    stream = pipe.streaming(mode)
    stream.reset()
    step = stream.step
    uses_force = stream.uses_force
    per = []
    for _ in range(5):
        for start in range(0, X.shape[0] - 100, 100):
            t0 = time.perf_counter()
            for k in range(start, start + 100):
                step(X[k], y[k - 1] if uses_force else None)
            per.append((time.perf_counter() - t0) / 100)
    return float(np.median(per)) * 1e6


def every_estimator(subject: object, repeats: int) -> None:
    """Training time and streaming step of every registered estimator, all 8 channels."""
    fs = extract_features(subject.paper_session(rng=np.random.default_rng(0)), channels=None)
    n_id = fs.n_windows // 2
    X_id, y_id = fs.X[:n_id], fs.y[:n_id]
    print(f"\nevery estimator, all 8 channels ({fs.X.shape[1]} inputs), {n_id} identification "
          f"windows; training median of {repeats}, goal < 2000 ms; step goal < 20 us for gbt")
    print(f"{'estimator':13s}{'train ms':>10s}{'step us':>9s}{'mode':>10s}")
    ref_step = None
    with threadpool_limits(limits=1, user_api="blas"):
        for name in ESTIMATOR_NAMES:
            params = {"random_state": 0} if name in ("mlp", "narx", "gbt") else {}
            if name in ("ss_kf", "ss", "mlp", "narx", "ridge", "gbt"):
                params["dt_s"] = fs.dt_s
            train = median_time(lambda n=name, p=params: make_estimator(n, **p).fit(X_id, y_id),
                                repeats)
            pipe = make_estimator(name, **params).fit(X_id, y_id)
            mode = "free_run" if "free_run" in pipe.modes else "one_step"
            try:
                step = stream_step_us(pipe, fs.X, fs.y, mode)
            except ValueError as exc:  # an unstable model has no free_run stream
                print(f"{name:13s}{train * 1e3:>10.2f}{'-':>9s}{mode:>10s}  ({exc})")
                continue
            if name == "ss_kf":
                ref_step = step
            flag = "ok" if train < 2.0 else "MISSED"
            if name == "gbt":
                flag += ", step " + ("ok" if step < 20.0 else "MISSED")
            print(f"{name:13s}{train * 1e3:>10.2f}{step:>9.2f}{mode:>10s}  {flag}")
    if ref_step is not None:
        print(f"reference: SS_KF step {ref_step:.2f} us in this run")


if __name__ == "__main__":
    sys.exit(main())
