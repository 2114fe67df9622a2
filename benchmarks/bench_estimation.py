"""Speed of the paper's SS_KF estimator against the paper's Table 3.

Prints, for one virtual subject's calibration session (first 50 % of windows):

- training time (RLS identification at n = 4 plus Kalman design), median;
- streaming step time per update in a Python loop, median;
- batch prediction throughput (updates per second);

each next to the paper's figure and the ratio, and the two speed goals as
``GOAL`` lines (``benchmarks/_timing.goal_line``), each against a reference measured in
the same run, interleaved:

- SS + KF training <= 0.5 ms (reference: the same fit with scipy's
  ``solve_discrete_are``, the previous Kalman design);
- batch prediction >= 20 M updates/s (reference: the previous path, which
  normalized ``U`` and ``y`` into new arrays, stacked them and ran one
  matrix-vector product per numerator lag).

Then, for every registered
estimator on all 8 channels (24 inputs), training time (goal < 2 s) and the
median streaming step (goal < 20 us for the tree model ``gbt``), with SS_KF's
step measured in the same run as the reference. Run with::

    .venv/bin/python benchmarks/bench_estimation.py [--repeats 200]

BLAS is limited to one thread: the matrices are tiny and threads only add noise.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy.signal
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

from estimation.features import extract_features  # noqa: E402
from estimation.kalman import design_kalman  # noqa: E402
from estimation.paper import TABLE3  # noqa: E402
from estimation.registry import ESTIMATOR_NAMES, make_estimator  # noqa: E402
from estimation.rls import rls  # noqa: E402
from estimation.state_space import identification_rows  # noqa: E402
from sim.user.subjects import make_population  # noqa: E402


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


def interleaved_medians(fns: dict[str, object], repeats: int) -> dict[str, float]:
    """Median wall time (s) of each candidate, calls interleaved so that load hits all alike."""
    for fn in fns.values():
        fn()
    times = {name: np.empty(repeats) for name in fns}
    for i in range(repeats):
        for name, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            times[name][i] = time.perf_counter() - t0
    return {name: float(np.median(t)) for name, t in times.items()}


def unfolded_prediction(pipe: object, U: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The previous batch path of ``ForcePipeline.predict`` (one_step), kept as the reference.

    Normalizes ``U`` and ``y`` into new arrays, stacks them, runs one
    matrix-vector product per numerator lag, ``lfilter`` and rescales.
    """
    sc, est = pipe.scaling_, pipe.estimator
    F, Gu, Gy, h = est.lti("one_step")
    V = np.hstack([sc.transform_u(U), sc.transform_y(y)[:, None]])
    G = np.hstack([Gu, Gy[:, None]])
    den = np.real(np.poly(F))
    nums = np.array([np.real(np.poly(F - np.outer(G[:, j], h))) - den
                     for j in range(G.shape[1])])
    n = V.shape[0]
    fir = np.zeros(n)
    for lag in range(1, F.shape[0] + 1):
        fir[lag:] += V[: n - lag] @ nums[:, lag]
    return sc.inverse_y(scipy.signal.lfilter([1.0], den, fir))


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

        # speed goals, each with its reference interleaved in the same run
        train_goal = interleaved_medians({
            "doubling": lambda: make_estimator("ss_kf", order=4).fit(X_id, y_id),
            "scipy": lambda: make_estimator("ss_kf", order=4,
                                            kalman_method="scipy").fit(X_id, y_id),
        }, args.repeats)
        batch_goal = interleaved_medians({
            "folded": lambda: pipe.predict(U_big, Y_big, mode="one_step"),
            "unfolded": lambda: unfolded_prediction(pipe, U_big, Y_big),
        }, 7)
        folded = pipe.predict(U_big, Y_big, mode="one_step")
        unfolded = unfolded_prediction(pipe, U_big, Y_big)
        batch_diff = float(np.abs(folded - unfolded).max() / np.abs(unfolded).max())
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
    print(f"\nspeed goals (BLAS 1 thread; load average {os.getloadavg()[0]:.2f} on "
          f"{os.cpu_count()} cores; medians, candidates interleaved):")
    goal_line("SS + KF training <= 0.5 ms", train_goal["doubling"] * 1e3, "ms", limit=0.5,
              better="lower",
              reference=f"same fit with scipy's DARE {train_goal['scipy'] * 1e3:.3f} ms")
    rate_folded = n_batch / batch_goal["folded"] / 1e6
    rate_unfolded = n_batch / batch_goal["unfolded"] / 1e6
    goal_line("batch prediction >= 20 M updates/s", rate_folded, "M/s", limit=20.0,
              better="higher",
              reference=f"previous unfolded path {rate_unfolded:.1f} M/s "
                        f"(max relative difference {batch_diff:.1e})")
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
