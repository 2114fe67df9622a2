"""Ctrl-C and SIGTERM stop a running sweep: exit 130/143, nothing failed, resume completes it."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

HERE = Path(__file__).parent
N = 6
SWEEP = f"""\
name: stop
seed: 3
base:
  object: {{name: can}}
grid:
  object.mass_kg: {[0.1 * (i + 1) for i in range(N)]}
"""


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE), env.get("PYTHONPATH")) if p)
    env.pop("GRIPLOOP_TRACEBACK", None)
    env["OMP_NUM_THREADS"] = "1"
    return env


def _rows(db: Path) -> list[tuple[str, str, int]]:
    if not db.exists():
        return []
    try:
        with sqlite3.connect(db, timeout=5) as conn:
            return conn.execute("SELECT hash, status, attempts FROM results").fetchall()
    except sqlite3.OperationalError:  # tables not created yet
        return []


def _claims(db: Path) -> int:
    with sqlite3.connect(db, timeout=5) as conn:
        return conn.execute("SELECT COUNT(*) FROM claims").fetchone()[0]


@pytest.mark.slow
@pytest.mark.parametrize(("signum", "status"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)],
                         ids=["ctrl-c", "sigterm"])
def test_a_stopped_sweep_stores_no_failure_and_resumes(tmp_path, signum, status):
    path = tmp_path / "stop.yaml"
    path.write_text(textwrap.dedent(SWEEP))
    db = tmp_path / "r.sqlite"
    # tasks:solves_qps spends its scenario inside OSQP, which catches SIGINT itself
    argv = [sys.executable, "-m", "scenarios.cli", "sweep", str(path), "--db", str(db),
            "--task", "tasks:solves_qps"]
    proc = subprocess.Popen(argv, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    deadline = time.monotonic() + 60
    while not _rows(db) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    time.sleep(0.4)  # the next scenario is inside its solves now
    if signum == signal.SIGINT:
        os.killpg(proc.pid, signum)  # as a terminal's Ctrl-C: the whole process group
    else:
        os.kill(proc.pid, signum)  # as kill(1): the driver only
    sent = time.monotonic()
    out, err = proc.communicate(timeout=30)
    assert time.monotonic() - sent < 5.0, "the sweep did not stop promptly"
    assert proc.returncode == status, err
    assert f"stopped by {signal.Signals(signum).name}" in err
    assert "Traceback" not in err and "osqp" not in err.lower(), err
    assert len(err.strip().splitlines()) <= 3, err  # the progress bar and one line
    stopped = _rows(db)
    assert 1 <= len(stopped) < N and all(s == "ok" for _, s, _ in stopped), stopped
    assert _claims(db) == 0

    rerun = subprocess.run([*argv, "--no-progress"], env=_env(), capture_output=True, text=True,
                           timeout=120)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{len(stopped)} already stored, {N - len(stopped)} ok, 0 failed" in rerun.stdout
    rows = _rows(db)
    assert len(rows) == N and all(s == "ok" and a == 1 for _, s, a in rows), rows


def test_the_sandbox_child_never_sees_a_terminal_ctrl_c():
    sys.path.insert(0, str(HERE))
    try:
        from scenarios.execution.sweep import Sandbox
        from scenarios.schema import parse_scenario

        scenario = parse_scenario({"kind": "episode", "seed": 1}, source="test")
        with Sandbox() as box:
            outcome = box.run("tasks:signal_state", scenario, "h", 30.0)
    finally:
        sys.path.remove(str(HERE))
    assert outcome.status == "ok", outcome.error
    child = outcome.result
    assert child["pid"] != os.getpid()
    assert child["pgid"] == child["pid"] != os.getpgid(0)  # its own process group
    assert child["sigint_ignored"]
