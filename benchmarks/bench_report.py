"""Report speed and size: a whole ``griploop report`` process on the demo's results store.

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/bench_report.py [--repeat 3]
[--store demo_out/results.sqlite] [--reproduction demo_out/reproduce.json]``

Goals (issue 22):

- ``griploop report demo_out/results.sqlite --out DIR --reproduction
  demo_out/reproduce.json`` (what ``griploop demo`` runs: 54 episodes, the
  reproduction JSON, the rendered grasp) takes at most 5 s of wall time on 2
  cores, median of ``--repeat`` runs (the spread is printed);
- the output directory holds at most 1.5 MB.

Each run is a new ``python -m scenarios.cli report`` process of this tree into a new
directory, so imports, the store read and the frame's child process are all counted.
Main before issue 22 (commit 61d0d64, same store and command, this machine): 24.8 s median
(24.0-29.5 s) and 3.04 MB, 79 PNG images.

Without ``demo_out/`` (run ``make demo`` first for the goals' figures) the benchmark
runs the first ``--scenarios`` scenarios of ``scenarios/library/demo.yaml`` into a
temporary store and reports on it without a reproduction JSON; its GOAL lines then name
that store, and the goals, set for the demo store, are only indicative. On a machine
shared with other jobs the figures are pessimistic; the load average is printed.
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
DEMO_STORE = ROOT / "demo_out" / "results.sqlite"
DEMO_JSON = ROOT / "demo_out" / "reproduce.json"
TIME_LIMIT_S = 5.0
SIZE_LIMIT_MB = 1.5


def small_store(path: Path, n: int) -> Path:
    """The first ``n`` scenarios of the demo sweep, run into a new store at ``path``."""
    from scenarios.execution.sweep import SweepExecution, plan, run_sweep
    from scenarios.schema import expand_sweep, load_sweep
    from scenarios.store import ResultStore

    spec = load_sweep(ROOT / "scenarios" / "library" / "demo.yaml")
    with ResultStore(path) as store:
        run_sweep(plan(expand_sweep(spec))[:n], store, SweepExecution(workers=1),
                  sweep_name=spec.name, progress=False)
    return path


def directory_bytes(path: Path) -> int:
    """Total size of the files under ``path``, bytes."""
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--store", type=Path, default=DEMO_STORE)
    parser.add_argument("--reproduction", type=Path, default=DEMO_JSON,
                        help="reproduction JSON (used when it exists)")
    parser.add_argument("--repeat", type=int, default=3, help="timed report processes")
    parser.add_argument("--scenarios", type=int, default=12,
                        help="episodes of the fallback store (when --store is missing)")
    args = parser.parse_args()
    os.environ.setdefault("MUJOCO_GL", "egl")
    os.environ.setdefault("MPLBACKEND", "Agg")
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"]
                                     if env.get("PYTHONPATH") else "")
    print("command:", shlex.join([sys.executable, *sys.argv]))
    with tempfile.TemporaryDirectory(prefix="bench-report-") as name:
        tmp = Path(name)
        store, label = args.store, "the demo store"
        if not store.is_file():
            print(f"{store} not found (run make demo for the demo store): running the first "
                  f"{args.scenarios} scenarios of demo.yaml into a temporary store")
            t0 = time.perf_counter()
            store = small_store(tmp / "results.sqlite", args.scenarios)
            print(f"  store built in {time.perf_counter() - t0:.1f} s")
            label = f"a {args.scenarios}-episode demo store"
        argv = [sys.executable, "-m", "scenarios.cli", "report", str(store)]
        if args.reproduction.is_file() and store == args.store:
            argv += ["--reproduction", str(args.reproduction)]
        else:
            label += " without reproduction JSON"
        print(f"store: {store} ({label}); {os.cpu_count()} CPUs, load average "
              f"{os.getloadavg()[0]:.2f}")
        times, sizes = [], []
        for i in range(args.repeat):
            out = tmp / f"report{i}"
            cmd = [*argv, "--out", str(out)]
            if i == 0:
                print("timed:", shlex.join(cmd))
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True,
                                  check=False)
            times.append(time.perf_counter() - t0)
            if proc.returncode != 0:
                print(proc.stdout + proc.stderr)
                raise SystemExit(f"griploop report exited {proc.returncode}")
            sizes.append(directory_bytes(out))
            print(f"  run {i + 1}: {times[-1]:.2f} s, {sizes[-1] / 1e6:.3f} MB; "
                  f"{proc.stdout.splitlines()[0]}")
        print(f"load average after: {os.getloadavg()[0]:.2f}")
    median = statistics.median(times)
    spread = f"{min(times):.2f}-{max(times):.2f} s over {len(times)} runs"
    demo = label == "the demo store"  # main's figures were measured on that store only
    goal_line(f"griploop report of {label} <= {TIME_LIMIT_S:g} s (median)", median, "s",
              limit=TIME_LIMIT_S, reference=f"spread {spread}"
              + ("; main at 61d0d64: 24.8 s" if demo else ""))
    goal_line(f"report of {label} <= {SIZE_LIMIT_MB:g} MB", max(sizes) / 1e6, "MB",
              limit=SIZE_LIMIT_MB, reference="main at 61d0d64: 3.04 MB" if demo else "")
    return 0


if __name__ == "__main__":
    sys.exit(main())
