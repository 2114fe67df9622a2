"""Hashes of every closed-loop trace a set of commands runs: the same seeds, the same numbers?

Run: ``MUJOCO_GL=egl .venv/bin/python benchmarks/trace_hashes.py [--only NAME,...] [--json F]``

A refactor of the trial loop must not move a figure where nothing was meant to change.
This script runs griploop commands in this process (one worker, a fresh practice cache,
warm designs) and hashes, for every :class:`~sim.hand.grasp_env.GraspEnv` they step, the
sequence of (action, reference, grip force, object height, wrist height, slip speed)
after every step: the physical trace of the trial, whatever code assembled it. It prints
one line per command: the number of environments and control steps, and the SHA-256
of their hashes in order (first 16 hex digits). Run it on two source trees
(``PYTHONPATH=TREE``) on one machine and compare the lines; on another machine the
numbers may differ in the last bits (docs/DEVELOPMENT.md), so compare on one.

The commands (small versions of the demo sweep, ``compare-references`` for a practised
PID user and a novice lead-lag user, and one run of each benchmark) are listed in
:data:`COMMANDS`; the practice lifts run in each command (the practice cache is emptied
first), so their traces are covered too.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import shutil
import struct
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("MPLBACKEND", "Agg")

#: name -> griploop arguments (run in this process, one worker)
COMMANDS: dict[str, list[str]] = {
    "demo_sweep": ["sweep", "{library}/demo.yaml", "--workers", "1", "--db", "{tmp}/demo.sqlite",
                   "--no-progress"],
    "compare_pid_practised": ["compare-references", "--object", "can", "--controller", "pid",
                              "--subjects", "2", "--seed", "3"],
    "compare_lead_lag_novice": ["compare-references", "--object", "can", "--controller",
                                "lead_lag", "--subjects", "2", "--seed", "3", "--practice",
                                "0"],
    "eggs": ["eggs", "--controller", "pid", "--estimator", "mlp", "--subjects", "1",
             "--transfers", "1", "--eggs", "1.5,6", "--feedback", "none,force_vibration",
             "--no-progress"],
    "slip_recovery": ["slip-recovery", "--controller", "pid", "--estimator", "mlp",
                      "--subjects", "1", "--trials", "2", "--feedback", "none,slip_vibration",
                      "--no-progress"],
    "force_matching": ["force-matching", "--controller", "pid", "--estimator", "mlp",
                       "--subjects", "1", "--targets", "0.4",
                       "--feedback", "none,force_vibration", "--no-progress"],
    "transfers": ["transfers", "--controller", "pid", "--estimator", "mlp", "--subjects", "1",
                  "--duration-s", "20", "--intact", "--no-progress"],
    "force_matching_scripted": ["force-matching", "--controller", "pid", "--estimator", "ss_kf",
                                "--subjects", "1", "--targets", "0.4",
                                "--user", "scripted", "--feedback", "none", "--no-progress"],
    "episode_compiled": ["episode", "--controller", "pid", "--estimator", "ss_kf", "--object",
                         "can", "--subject", "2", "--seed", "4", "--compiled"],
    "episode_scripted": ["episode", "--controller", "pid", "--estimator", "latent_kf",
                         "--object", "can", "--subject", "1", "--seed", "1", "--user",
                         "scripted"],
    "episode_scripted_block": ["episode", "--controller", "pid", "--estimator", "latent_kf",
                               "--object", "block", "--subject", "3", "--seed", "0", "--user",
                               "scripted"],
}


class _Hashes:
    """Per-environment SHA-256 of the steps' physical readings, in the order envs are closed.

    Scenarios of a sweep run in forked children: each environment's hash is appended to
    a file when it is closed (or reset again), so that the children's hashes reach this
    process in order.
    """

    def __init__(self, path: Path) -> None:
        self.path = path
        self.path.write_text("")

    def install(self) -> None:
        from sim.hand.grasp_env import GraspEnv

        path = self.path
        reset, step, close = GraspEnv.reset, GraspEnv.step, GraspEnv.close

        def flush(env):  # type: ignore[no-untyped-def]
            state = getattr(env, "_trace_hash", None)
            if state is not None and state[1][0] > 0:
                with open(path, "a") as f:
                    f.write(f"{state[1][0]} {state[0].hexdigest()}\n")
            env._trace_hash = None

        def hashed_reset(env, *args, **kw):  # type: ignore[no-untyped-def]
            flush(env)
            out = reset(env, *args, **kw)
            env._trace_hash = (hashlib.sha256(), [0])
            return out

        def hashed_step(env, action):  # type: ignore[no-untyped-def]
            out = step(env, action)
            info = out[4]
            h, n = env._trace_hash
            h.update(struct.pack("<7d", float(action[0]), info["reference_n"],
                                 info["grip_force_n"], info["object_height_m"],
                                 info["wrist_height_m"], info["slip_speed_m_s"],
                                 info["finger_position_rad"]))
            n[0] += 1
            return out

        def hashed_close(env):  # type: ignore[no-untyped-def]
            flush(env)
            return close(env)

        GraspEnv.reset, GraspEnv.step, GraspEnv.close = hashed_reset, hashed_step, hashed_close

    def take(self) -> tuple[int, int, str]:
        """Environments stepped, steps, and the combined hash since the last call."""
        import gc

        gc.collect()
        lines = [line.split() for line in self.path.read_text().splitlines() if line]
        self.path.write_text("")
        total = hashlib.sha256()
        for _, digest in lines:
            total.update(bytes.fromhex(digest))
        return len(lines), sum(int(n) for n, _ in lines), total.hexdigest()[:16]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default=None, help="comma-separated command names")
    parser.add_argument("--json", type=Path, default=None, help="also write the table here")
    args = parser.parse_args(argv)
    from scenarios.cli.main import main as griploop

    names = list(COMMANDS) if args.only is None else args.only.split(",")
    library = Path(__import__("scenarios").__file__).parent / "library"
    cache = Path(tempfile.mkdtemp(prefix="griploop-hash-cache-"))
    os.environ["GRIPLOOP_CACHE_DIR"] = str(cache)
    hashes = _Hashes(cache / "trace-hashes.txt")
    hashes.install()
    table = {}
    try:
        for name in names:
            with tempfile.TemporaryDirectory() as tmp:
                argv_i = [a.format(library=library, tmp=tmp) for a in COMMANDS[name]]
                shutil.rmtree(cache / "practice", ignore_errors=True)
                hashes.take()
                t0 = time.perf_counter()
                err = io.StringIO()
                with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
                    try:
                        status = griploop([*argv_i, "--json", f"{tmp}/out.json"]
                                          if name != "demo_sweep" else argv_i)
                    except SystemExit as exc:
                        status = exc.code
                if status:
                    print(f"{name}: {err.getvalue().strip()}", file=sys.stderr)
                took = time.perf_counter() - t0
                n_env, n_steps, digest = hashes.take()
                outcomes = _outcomes(Path(tmp) / "out.json")
            table[name] = {"status": status, "envs": n_env, "steps": n_steps, "hash": digest,
                           "outcomes": outcomes}
            print(f"{name:<26} exit {status}  {n_env:>4} envs {n_steps:>8} steps  {digest}"
                  f"  {outcomes or ''}  ({took:.0f} s)", flush=True)
    finally:
        shutil.rmtree(cache, ignore_errors=True)
    if args.json is not None:
        args.json.write_text(json.dumps(table, indent=1))
    return 0


def _outcomes(path: Path) -> dict[str, int] | str | None:
    """An episode's outcome, from its JSON (None for other commands)."""
    if not path.exists():
        return None
    data = json.loads(path.read_text())
    metrics = data.get("metrics")
    if isinstance(metrics, dict) and "outcome" in metrics:
        return f"outcome {metrics['outcome']}, attempts {metrics.get('attempts')}"
    return None


if __name__ == "__main__":
    sys.exit(main())
