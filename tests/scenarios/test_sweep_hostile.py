"""Bounded sweeps: time limits, scenarios that kill their process, two drivers, huge designs."""

from __future__ import annotations

import os
import socket
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pytest
import tasks
from test_cli_sweep import cli_env, run_main, write

from scenarios.execution.sweep import SweepExecution, plan, run_sweep
from scenarios.schema import expand_sweep, parse_sweep
from scenarios.store import ResultStore


def planned(task: str, masses=(0.2, 1.5, 0.5), kinds=("pid", "mpc")):
    spec = parse_sweep({"name": "hostile", "seed": 3, "base": {"object": {"name": "cup"}},
                        "grid": {"object.mass_kg": list(masses), "controller.kind": list(kinds)}})
    return plan(expand_sweep(spec), task)


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


@pytest.mark.parametrize("workers", [1, pytest.param(2, marks=pytest.mark.slow)])
def test_scenario_past_its_time_limit_is_a_timeout_row(tmp_path, workers):
    items = planned("tasks:sleeps_past_limit")
    t0 = time.perf_counter()
    with ResultStore(tmp_path / "r.sqlite") as store:
        summary = run_sweep(items, store, SweepExecution("tasks:sleeps_past_limit",
                                                         workers=workers, time_limit_s=1.0),
                            progress=False)
        rows = {r["hash"]: r for r in store.rows()}
    assert time.perf_counter() - t0 < 30
    assert (summary.ok, summary.failed) == (4, 2)
    for p in items:
        row = rows[p.hash]
        if p.scenario.object.mass_kg > 1.0:
            assert row["status"] == "failed"
            assert row["error"].startswith("timeout: still running after 1 s")
            assert 1.0 <= row["duration_s"] < 5.0
        else:  # the same values as in-process
            assert row["result"] == {k: v for k, v in tasks.seeded(p.scenario).items()
                                     if k != "traces"} | {"n_draws": 3}


def _running(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_timeout_stops_the_processes_the_scenario_started(tmp_path, monkeypatch):
    runs = tmp_path / "pids.txt"
    monkeypatch.setenv("GRIPLOOP_TEST_RUNS", str(runs))
    items = planned("tasks:spawns_then_hangs", masses=(0.2,), kinds=("pid",))
    with ResultStore(tmp_path / "r.sqlite") as store:
        summary = run_sweep(items, store,
                            SweepExecution("tasks:spawns_then_hangs", time_limit_s=1.0),
                            progress=False)
    assert (summary.ok, summary.failed) == (0, 1)
    (pid,) = (int(s) for s in runs.read_text().split())
    deadline = time.monotonic() + 10
    while _running(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = _running(pid)
    if alive:
        os.kill(pid, 9)
    assert not alive, "the scenario's subprocess outlived its timeout"


def test_scenario_that_kills_its_process_is_failed_and_not_retried_forever(tmp_path):
    items = planned("tasks:kills_itself")
    with ResultStore(tmp_path / "r.sqlite") as store:
        first = run_sweep(items, store, SweepExecution("tasks:kills_itself"), progress=False)
        failed = store.rows(status="failed")
        again = run_sweep(items, store, SweepExecution("tasks:kills_itself"), progress=False)
    assert (first.ok, first.failed) == (4, 2)
    assert all(r["error"].startswith("killed: the scenario killed its process twice") and
               "SIGKILL" in r["error"] for r in failed)
    assert (again.skipped, again.ok, again.failed) == (6, 0, 0)


def test_scenario_whose_driver_died_twice_is_failed_on_the_next_resume(tmp_path):
    items = planned("tasks:seeded", masses=(0.2,), kinds=("pid",))
    (p,) = items
    host = socket.gethostname()
    with ResultStore(tmp_path / "r.sqlite") as store:
        # two drivers died while running it: each left its claim behind
        assert store.claim(p.hash, f"{host}:{_dead_pid()}:a", 3600) == "run"
        assert store.claim(p.hash, f"{host}:{_dead_pid()}:b", 3600) == "run"
        summary = run_sweep(items, store, SweepExecution("tasks:seeded"), progress=False)
        (row,) = store.rows()
    assert (summary.ok, summary.failed) == (0, 1)
    assert row["error"].startswith("killed: its driver process died twice")


def test_claim_of_a_live_driver_is_left_alone(tmp_path):
    (p,) = planned("tasks:seeded", masses=(0.2,), kinds=("pid",))
    with ResultStore(tmp_path / "r.sqlite") as store:
        other = f"{socket.gethostname()}:{os.getppid()}:x"  # alive
        assert store.claim(p.hash, other, 3600) == "run"
        assert store.claim(p.hash, "me", 3600) == "busy"
        assert store.claim(p.hash, other, 3600) == "run"  # its own claim
        store.release_claims(other)
        assert store.claim(p.hash, "me", 3600) == "run"


def test_two_drivers_on_one_store_run_each_scenario_once(tmp_path):
    path = write(tmp_path)  # 24 scenarios
    db = tmp_path / "r.sqlite"
    runs = tmp_path / "runs.txt"
    # each driver's first scenario waits for the other: both run some, however slow the start
    env = cli_env() | {"GRIPLOOP_TEST_RUNS": str(runs), "GRIPLOOP_TEST_DRIVERS": "2"}
    argv = [sys.executable, "-m", "scenarios.cli", "sweep", str(path), "--db", str(db),
            "--task", "tasks:counted", "--no-progress"]
    first = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
    time.sleep(0.3)
    second = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True)
    outs = [proc.communicate(timeout=120) for proc in (first, second)]
    assert first.returncode == 0 and second.returncode == 0, outs
    seeds = [line.split()[0] for line in runs.read_text().splitlines()]
    assert len(seeds) == len(set(seeds)) == 24
    with sqlite3.connect(db) as conn:
        rows = conn.execute("SELECT status, attempts FROM results").fetchall()
        claims = conn.execute("SELECT COUNT(*) FROM claims").fetchone()[0]
    assert len(rows) == 24 and all(r == ("ok", 1) for r in rows) and claims == 0
    ran = [int(out.split(" already stored, ")[1].split(" ok")[0]) for out, _ in outs]
    assert sum(ran) == 24 and all(n > 0 for n in ran)


def test_huge_design_is_counted_not_built(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)
    axes = "\n".join(
        f"  {path}: [{', '.join(str(v) for v in values)}]"
        for path, values in {
            "object.friction": np.round(np.linspace(0.2, 1.5, 10), 3),
            "object.mass_kg": np.round(np.linspace(0.1, 1.0, 10), 3),
            "subject.subject_id": range(1, 11),
            "subject.extra_noise_lsb": range(10),
            "subject.population_seed": range(10),
            "controller.phase_margin_deg": range(30, 40),
            "controller.safety_factor": np.round(np.linspace(1, 2, 10), 3),
        }.items()
    )
    path = write(tmp_path, "name: huge\ngrid:\n" + axes + "\n")
    db = tmp_path / "r.sqlite"
    t0 = time.perf_counter()
    code, out, _ = run_main(capsys, "sweep", str(path), "--db", str(db), "--dry-run")
    assert code == 0 and out.startswith("huge: 10000000 scenarios, above --max-scenarios 100000")
    code, out, _ = run_main(capsys, "sweep", str(path), "--db", str(db), "--dry-run",
                            "--max-scenarios", "0")
    assert code == 0 and out.startswith("huge: 10000000 scenarios (too many")
    code, out, err = run_main(capsys, "sweep", str(path), "--db", str(db))
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "design: expected at most 100000 scenarios, found 10000000" in err
    assert time.perf_counter() - t0 < 5
    assert not db.exists()


def test_time_limit_is_a_sweep_field(tmp_path, capsys):
    path = write(tmp_path, "name: lim\ntime_limit_s: 1\nbase:\n  object: {name: cup}\n"
                 "grid:\n  object.mass_kg: [0.2, 1.5]\n")
    db = tmp_path / "r.sqlite"
    code, out, _ = run_main(capsys, "sweep", str(path), "--db", str(db), "--task",
                            "tasks:sleeps_past_limit", "--no-progress")
    assert code == 0 and "1 ok, 1 failed" in out
    with ResultStore(db, read_only=True) as store:
        (row,) = store.rows(status="failed")
    assert row["error"].startswith("timeout:")


def test_threads_of_one_worker_process_do_not_share_a_sandbox():
    # a dask worker started with several threads runs several scenarios at once
    import concurrent.futures

    from scenarios.execution import sweep

    items = planned("tasks:sleepy", masses=(0.2, 0.5, 0.7, 0.9), kinds=("pid",))
    with concurrent.futures.ThreadPoolExecutor(len(items)) as pool:
        outs = list(pool.map(
            lambda p: sweep.execute_limited("tasks:sleepy", p.scenario, p.hash, 30.0), items))
    for p, out in zip(items, outs, strict=True):
        assert out.status == "ok", out.error
        assert out.hash == p.hash and out.result["draw"] == tasks.seeded(p.scenario)["draw"]


@pytest.mark.slow
def test_ctrl_c_stops_two_local_workers_and_their_children(tmp_path):
    """Ctrl-C on a 2-worker sweep: exit 130 at once, no child left, no claim, resume completes."""
    import signal

    from test_cli_interrupt import SWEEP, N, _claims, _env, _rows

    path = tmp_path / "stop.yaml"
    path.write_text(SWEEP)
    db = tmp_path / "r.sqlite"
    argv = [sys.executable, "-m", "scenarios.cli", "sweep", str(path), "--db", str(db),
            "--task", "tasks:solves_qps", "--workers", "2"]
    proc = subprocess.Popen(argv, env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    deadline = time.monotonic() + 60
    while not _rows(db) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    assert proc.poll() is None, proc.communicate()
    time.sleep(0.4)
    children = [int(p) for p in subprocess.run(["pgrep", "-P", str(proc.pid)],
                                               capture_output=True, text=True).stdout.split()]
    assert len(children) == 2  # the two workers, forked from the driver
    os.killpg(proc.pid, signal.SIGINT)  # a terminal's Ctrl-C: the whole process group
    sent = time.monotonic()
    _, err = proc.communicate(timeout=30)
    assert time.monotonic() - sent < 5.0 and proc.returncode == 130, err
    assert "stopped by SIGINT" in err and "Traceback" not in err
    assert not any(_running(pid) for pid in children)
    stopped = _rows(db)
    assert 1 <= len(stopped) < N and all(s == "ok" for _, s, _ in stopped) and _claims(db) == 0
    rerun = subprocess.run([*argv, "--no-progress"], env=_env(), capture_output=True, text=True,
                           timeout=120)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{len(stopped)} already stored, {N - len(stopped)} ok, 0 failed" in rerun.stdout
