"""The README's two commands from a fresh clone: ``make test`` and ``make demo`` (issue 22, item 5).

Run: ``.venv/bin/python benchmarks/bench_setup.py [--repeat 1] [--skip-test] [--skip-demo]``

Goals, measured as a new user meets them: ``git clone`` of this repository's HEAD
into a temporary directory, ``make .venv/.griploop-installed`` there (creating the
venv and installing griploop: untimed, printed), then

- ``make test`` (ruff and the whole suite, on one pytest-xdist worker per core) in at
  most 4 min;
- ``make demo`` in at most 60 s after installation, with an empty cache of its own
  (``GRIPLOOP_CACHE_DIR``: plant families linearized and controllers designed as on a new
  machine; ``transfer_mlp``'s default networks are read from the package, where ``make
  pretrained`` put them, as a clone has them); the same command with that cache warm is
  printed beside it, as is the time of each of the demo's steps.

Each is the median of ``--repeat`` runs (each demo run in an empty output directory and,
for the cold figure, an empty cache), with the spread. Uncommitted changes are not in the
clone. This takes several minutes; the machine is shared with other jobs, so the load
average is printed with every figure.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import goal_line  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TEST_LIMIT_S = 240.0
DEMO_LIMIT_S = 60.0


def timed(argv: list[str], cwd: Path, env: dict[str, str], log: Path) -> float:
    """Wall time of ``argv`` in ``cwd``, s; its output goes to ``log`` (fails loudly)."""
    t0 = time.perf_counter()
    with log.open("w") as out:
        code = subprocess.run(argv, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT
                              ).returncode
    seconds = time.perf_counter() - t0
    if code != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({code}); see {log}:\n"
                         + "\n".join(log.read_text().splitlines()[-20:]))
    return seconds


def spread(values: list[float]) -> str:
    return f"median {statistics.median(values):.1f} s, spread {min(values):.1f}-" \
           f"{max(values):.1f} s"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="runs of each (default 1)")
    parser.add_argument("--skip-test", action="store_true", help="do not time make test")
    parser.add_argument("--skip-demo", action="store_true", help="do not time make demo")
    args = parser.parse_args()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                          capture_output=True).stdout.strip()
    with tempfile.TemporaryDirectory(prefix="bench-setup-") as tmp:
        clone = Path(tmp) / "fresh"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        # no GRIPLOOP_CACHE_DIR: the suite makes an empty cache of its own each run
        env = {k: v for k, v in os.environ.items()
               if k not in ("PYTHONPATH", "VIRTUAL_ENV", "GRIPLOOP_CACHE_DIR")}
        install = timed(["make", ".venv/.griploop-installed"], clone, env,
                        Path(tmp) / "install.log")
        print(f"fresh clone of {head}: venv and installation {install:.1f} s (untimed)",
              flush=True)
        if not args.skip_test:
            tests = []
            for i in range(args.repeat):
                seconds = timed(["make", "test"], clone, env, Path(tmp) / f"test{i}.log")
                summary = next((line for line in reversed(
                    (Path(tmp) / f"test{i}.log").read_text().splitlines())
                    if re.search(r"\d+ passed", line)), "")
                tests.append(seconds)
                print(f"make test: {seconds:.1f} s ({summary.strip(' =')}; load average "
                      f"{os.getloadavg()[0]:.2f})", flush=True)
            goal_line(f"make test <= {TEST_LIMIT_S / 60:g} min from a fresh clone (median of "
                      f"{args.repeat})", statistics.median(tests), "s", limit=TEST_LIMIT_S,
                      reference=spread(tests) + "; after installation")
        if not args.skip_demo:
            cold, warm = [], []
            for i in range(args.repeat):
                demo_env = {**env, "GRIPLOOP_CACHE_DIR": str(Path(tmp) / f"cache-demo{i}")}
                for runs, label in ((cold, "empty cache"), (warm, "warm cache")):
                    shutil.rmtree(clone / "demo_out", ignore_errors=True)
                    log = Path(tmp) / f"demo{i}-{len(runs)}-{label[:4]}.log"
                    runs.append(timed(["make", "demo"], clone, demo_env, log))
                    steps = log.read_text().partition("=== time per step")[2]
                    print(f"make demo, {label}: {runs[-1]:.1f} s (load average "
                          f"{os.getloadavg()[0]:.2f}); per step:"
                          + "".join(f"\n  {line.strip()}" for line in steps.splitlines()
                                    if line.strip().endswith(" s") and "finished" not in line),
                          flush=True)
            goal_line(f"make demo <= {DEMO_LIMIT_S:g} s after installation, empty cache "
                      f"(median of {args.repeat})", statistics.median(cold), "s",
                      limit=DEMO_LIMIT_S, reference=f"{spread(cold)}; warm cache "
                      f"{spread(warm)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
