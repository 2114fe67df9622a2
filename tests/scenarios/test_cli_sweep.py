"""``griploop sweep`` and ``griploop export``: errors, resume after SIGKILL, export."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from scenarios.cli import main
from scenarios.execution.sweep import plan
from scenarios.schema import expand_sweep, load_sweep

HERE = Path(__file__).parent
SWEEP = """\
name: cli
seed: 8
base:
  object: {name: ball}
grid:
  object.mass_kg: [0.05, 0.1, 0.2, 0.4, 0.8, 1.6]
  object.friction: [0.3, 0.6, 0.9, 1.2]
"""


def write(tmp_path: Path, text: str = SWEEP, name: str = "sweep.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def cli_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(HERE), env.get("PYTHONPATH")) if p)
    env.pop("GRIPLOOP_TRACEBACK", None)
    return env


def run_main(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


# ------------------------------------------------------------------ user errors


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("base:\n  object: {name: cup\ngrid: [\n", ":3:5: malformed YAML"),
        ("base:\n  objet: {name: cup}\n", ":2: base: unknown key 'objet'"),
        ("base:\n  object: {friction: 9}\n", ":2: base.object.friction: expected less than"),
        ("base: {}\ngrid:\n  subject.fatigue_per_min: [0.1, 0.9]\n",
         ":3: grid.subject.fatigue_per_min[1]"),
    ],
    ids=["malformed", "unknown-key", "bad-range", "bad-grid-value"],
)
def test_bad_files_give_one_line_and_exit_2(tmp_path, capsys, monkeypatch, text, expected):
    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)
    path = write(tmp_path, text)
    code, out, err = run_main(capsys, "sweep", str(path), "--db", str(tmp_path / "r.sqlite"))
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"griploop sweep: error: {path}{expected}")


def test_missing_file_gives_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)
    code, _, err = run_main(capsys, "sweep", str(tmp_path / "nope.yaml"))
    assert code == 2
    assert err == f"griploop sweep: error: {tmp_path / 'nope.yaml'}: no such scenario file " \
                  "(expected a YAML sweep file)\n"


def test_missing_runner_and_conflicting_options_exit_2(tmp_path, capsys, monkeypatch):
    from scenarios.runners import dispatch as runner

    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)
    monkeypatch.delitem(runner._REGISTRY, "episode")  # as in a build without the hand
    path = write(tmp_path)
    db = str(tmp_path / "r.sqlite")
    code, _, err = run_main(capsys, "sweep", str(path), "--db", db)
    assert code == 2 and "no runner registered for scenario kind 'episode'" in err
    code, _, err = run_main(capsys, "sweep", str(path), "--workers", "2", "--scheduler", "x:1")
    assert code == 2 and "give --workers or --scheduler, not both" in err
    code, _, err = run_main(capsys, "sweep", str(path), "--db", db, "--task", "tasks:nothing")
    assert code == 2 and "has no callable 'nothing'" in err


def test_subprocess_error_has_no_traceback(tmp_path):
    path = write(tmp_path, "base:\n  object: {mass_kg: -1}\n")
    proc = subprocess.run(
        [sys.executable, "-m", "scenarios.cli", "sweep", str(path), "--db",
         str(tmp_path / "r.sqlite")],
        capture_output=True, text=True, env=cli_env(), timeout=60,
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr
    assert f"{path}:2: base.object.mass_kg" in proc.stderr


@pytest.mark.parametrize("command", ["sweep", "export"])
def test_help_is_complete(capsys, command):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    text = capsys.readouterr().out
    options = {"sweep": ["--workers", "--scheduler", "--db", "--task", "--retry-failed",
                         "--dry-run", "--no-progress"],
               "export": ["--out", "--format", "--sweep", "--status"]}[command]
    assert all(opt in text for opt in options)


# ------------------------------------------------------------------ run, resume, export


def test_sweep_dry_run_then_export(tmp_path, capsys):
    path = write(tmp_path)
    db = tmp_path / "r.sqlite"
    code, out, _ = run_main(capsys, "sweep", str(path), "--db", str(db), "--task",
                            "tasks:heavy_fails", "--dry-run")
    assert code == 0 and out == "cli: 24 scenarios, 0 stored, 24 to run\n"
    code, out, err = run_main(capsys, "sweep", str(path), "--db", str(db), "--task",
                              "tasks:heavy_fails")
    assert code == 0
    assert out.startswith("cli: 24 scenarios, 0 already stored, 20 ok, 4 failed in ")
    assert "24/24 done, 4 failed" in err.splitlines()[-1]
    code, out, _ = run_main(capsys, "export", str(db), "--out", str(tmp_path / "x" / "t"))
    assert code == 0 and out.split() == [str(tmp_path / "x" / "t.parquet"),
                                         str(tmp_path / "x" / "t.csv")]
    table = pq.read_table(tmp_path / "x" / "t.parquet").to_pydict()
    assert len(table["hash"]) == 24 and table["status"].count("failed") == 4
    assert sorted(set(table["config.object.mass_kg"])) == [0.05, 0.1, 0.2, 0.4, 0.8, 1.6]
    code, out, _ = run_main(capsys, "export", str(db), "--format", "csv", "--sweep", "cli",
                            "--status", "failed")
    assert code == 0 and out == f"{tmp_path / 'r.csv'}\n"
    code, _, err = run_main(capsys, "export", str(tmp_path / "absent.sqlite"))
    assert code == 2 and "no such results store" in err


def test_a_sweep_then_a_read_only_open_leave_no_wal_or_shm_beside_the_store(tmp_path, capsys):
    # what griploop demo does to its store: a sweep on two forked workers, then a read-only
    # open (its report; here an export, which opens the store the same way)
    path = write(tmp_path)
    db = tmp_path / "results.sqlite"
    for argv in (("sweep", str(path), "--db", str(db), "--task", "tasks:seeded",
                  "--workers", "2"),
                 ("export", str(db), "--out", str(tmp_path / "table"))):
        code, _, err = run_main(capsys, *argv)
        assert code == 0, err
        assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(db.name)) == [
            db.name], argv


def test_reproduction_sweep_end_to_end(tmp_path, capsys):
    path = write(
        tmp_path,
        """\
        name: mini_paper
        base:
          kind: reproduction
          protocol: {name: paper_calibration}
        grid:
          subject.subject_id: [1, 2]
          estimator.name: [ss_kf, lda_qpf]
          estimator.mode: [one_step, free_run]
        """,
    )
    db = tmp_path / "r.sqlite"
    code, out, _ = run_main(capsys, "sweep", str(path), "--db", str(db), "--no-progress")
    assert code == 0 and "8 ok, 0 failed" in out
    code, _, _ = run_main(capsys, "export", str(db), "--format", "parquet")
    table = pq.read_table(tmp_path / "r.parquet").to_pydict()
    assert sorted(set(table["result.estimator"])) == ["lda_qpf", "ss_kf"]
    assert all(r2 <= 1.0 for r2 in table["result.r2"])
    one_step_ss_kf = [r2 for r2, name, mode in zip(table["result.r2"], table["result.estimator"],
                                                   table["result.mode"], strict=True)
                      if (name, mode) == ("ss_kf", "one_step")]
    assert len(one_step_ss_kf) == 2 and min(one_step_ss_kf) > 0.5
    assert set(table["result.mode"]) == {"one_step", "free_run"}


def _count_rows(db: Path) -> int:
    if not db.exists():
        return 0
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5) as conn:
            return conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
    except sqlite3.OperationalError:  # tables not created yet
        return 0


@pytest.mark.slow
def test_resume_after_sigkill_loses_and_duplicates_nothing(tmp_path):
    path = write(tmp_path)
    db = tmp_path / "r.sqlite"
    argv = [sys.executable, "-m", "scenarios.cli", "sweep", str(path), "--db", str(db),
            "--task", "tasks:sleepy", "--no-progress"]
    proc = subprocess.Popen(argv, env=cli_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 20
    while _count_rows(db) < 5 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
    os.kill(proc.pid, signal.SIGKILL)
    proc.communicate(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    with sqlite3.connect(db) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        before = dict(conn.execute("SELECT hash, finished_at FROM results").fetchall())
    assert 5 <= len(before) < 24

    rerun = subprocess.run(argv, env=cli_env(), capture_output=True, text=True, timeout=60)
    assert rerun.returncode == 0, rerun.stderr
    assert f"{len(before)} already stored, {24 - len(before)} ok, 0 failed" in rerun.stdout

    expected = {p.hash for p in plan(expand_sweep(load_sweep(path)), "tasks:sleepy")}
    with sqlite3.connect(db) as conn:
        rows = conn.execute("SELECT hash, status, finished_at, attempts FROM results").fetchall()
        members = conn.execute("SELECT COUNT(*) FROM sweep_members").fetchone()[0]
    hashes = [r[0] for r in rows]
    assert sorted(hashes) == sorted(expected) and len(hashes) == len(set(hashes)) == 24
    assert all(status == "ok" and attempts == 1 for _, status, _, attempts in rows)
    assert all(before[h] == t for h, _, t, _ in rows if h in before)
    assert members == 24
