"""A results store that fails cleanly: full disk, read-only media, corrupted and foreign files."""

from __future__ import annotations

import shutil
import sqlite3
import subprocess
from pathlib import Path

import pytest
from test_cli_sweep import run_main, write

from scenarios.execution.sweep import SweepExecution, plan, run_sweep
from scenarios.schema import expand_sweep, parse_sweep
from scenarios.store import ResultStore, StoreError


@pytest.fixture(autouse=True)
def _no_traceback(monkeypatch):
    monkeypatch.delenv("GRIPLOOP_TRACEBACK", raising=False)


def planned(n: int = 6):
    spec = parse_sweep({"name": "s", "seed": 1, "base": {"object": {"name": "cup"}},
                        "grid": {"object.mass_kg": [round(0.1 + 0.01 * i, 3) for i in range(n)]}})
    return plan(expand_sweep(spec), "tasks:seeded")


def make_store(path: Path, n: int = 6) -> Path:
    with ResultStore(path) as store:
        run_sweep(planned(n), store, SweepExecution("tasks:seeded"), progress=False, sweep_name="s")
    return path


def one_line_error(capsys, *argv: str) -> str:
    code, out, err = run_main(capsys, *argv)
    assert code == 2 and out == "", (code, out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


def test_foreign_sqlite_file_is_refused_and_left_unchanged(tmp_path, capsys):
    db = tmp_path / "contacts.sqlite"
    with sqlite3.connect(db) as conn:
        conn.execute("CREATE TABLE contacts (name TEXT, phone TEXT)")
        conn.execute("INSERT INTO contacts VALUES ('Ada', '123')")
    conn.close()
    before = db.read_bytes()
    sweep = write(tmp_path)
    for argv in (("export", str(db), "--out", str(tmp_path / "x")),
                 ("report", str(db), "--out", str(tmp_path / "rep"), "--no-render"),
                 ("sweep", str(sweep), "--db", str(db), "--task", "tasks:seeded"),
                 ("sweep", str(sweep), "--db", str(db), "--dry-run")):
        err = one_line_error(capsys, *argv)
        assert "not a griploop results store (found an SQLite database with tables " \
               "contacts); left unchanged" in err
    assert db.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("contacts")) == [
        "contacts.sqlite"]  # no -wal or -shm


def test_corrupted_store_gives_one_line(tmp_path, capsys):
    db = make_store(tmp_path / "r.sqlite", n=20)
    data = bytearray(db.read_bytes())
    page = 4096
    data[2 * page: len(data) - page] = b"\xa5" * (len(data) - 3 * page)
    db.write_bytes(bytes(data))
    err = one_line_error(capsys, "export", str(db), "--out", str(tmp_path / "x"))
    assert str(db) in err and "corrupted" in err
    header = bytearray(db.read_bytes())
    header[16:100] = b"\xff" * 84
    db.write_bytes(bytes(header))
    for argv in (("export", str(db)), ("report", str(db), "--out", str(tmp_path / "rep"))):
        err = one_line_error(capsys, *argv)
        assert str(db) in err


def test_disk_full_is_one_store_error_and_keeps_finished_rows(tmp_path):
    db = make_store(tmp_path / "r.sqlite", n=2)
    items = planned(40)
    with ResultStore(db) as store:
        (pages,) = store._conn.execute("PRAGMA page_count").fetchone()
        store._conn.execute(f"PRAGMA max_page_count = {pages + 3}")  # as a full disk does
        with pytest.raises(StoreError) as info:
            run_sweep(items, store, SweepExecution("tasks:seeded"), progress=False, sweep_name="s")
    message = str(info.value)
    assert message.startswith(f"{db}: cannot ") and "full" in message and "\n" not in message
    with ResultStore(db, read_only=True) as store:
        rows = store.rows()
    assert 2 <= len(rows) < 40 and all(r["status"] == "ok" for r in rows)


def _mount(path: Path, options: str) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                          capture_output=True)
    return done.returncode == 0


@pytest.fixture
def small_disk(tmp_path):
    disk = tmp_path / "small"
    if not _mount(disk, "size=96k"):
        pytest.skip("cannot mount a small tmpfs here (needs root)")
    yield disk
    subprocess.run(["umount", str(disk)], check=False)


def test_disk_full_through_the_cli(tmp_path, small_disk, capsys):
    sweep = write(tmp_path)
    db = small_disk / "r.sqlite"
    err = one_line_error(capsys, "sweep", str(sweep), "--db", str(db), "--task",
                         "tasks:seeded", "--no-progress")
    assert f"{db}: cannot" in err and "full" in err


@pytest.fixture
def read_only_dir(tmp_path):
    """A directory on read-only media, holding a results store with 6 rows."""
    source = tmp_path / "src.sqlite"
    spec = parse_sweep({"name": "s", "base": {"object": {"name": "cup"}},
                        "grid": {"object.mass_kg": [1.1, 1.2, 1.3, 1.4, 1.5, 1.6]}})
    with ResultStore(source) as store:  # failed rows: the report needs no episode fields
        run_sweep(plan(expand_sweep(spec), "tasks:heavy_fails"), store,
                  SweepExecution("tasks:heavy_fails"), progress=False, sweep_name="s")
    media = tmp_path / "media"
    if _mount(media, "size=4m"):
        shutil.copy(source, media / "r.sqlite")
        subprocess.run(["mount", "-o", "remount,ro", str(media)], check=True)
        yield media
        subprocess.run(["umount", str(media)], check=False)
        return
    if hasattr(__import__("os"), "geteuid") and __import__("os").geteuid() == 0:
        pytest.skip("root without mount: cannot make read-only media")
    media.mkdir()
    shutil.copy(source, media / "r.sqlite")
    (media / "r.sqlite").chmod(0o444)
    media.chmod(0o555)
    yield media
    media.chmod(0o755)


def test_read_only_store_is_exported_and_reported(tmp_path, read_only_dir, capsys):
    db = read_only_dir / "r.sqlite"
    before = db.read_bytes()
    code, out, err = run_main(capsys, "export", str(db), "--out", str(tmp_path / "out" / "t"))
    assert code == 0, err
    assert out.split() == [str(tmp_path / "out" / "t.parquet"), str(tmp_path / "out" / "t.csv")]
    assert len((tmp_path / "out" / "t.csv").read_text().splitlines()) == 7
    code, out, err = run_main(capsys, "report", str(db), "--out", str(tmp_path / "rep"),
                              "--no-render")
    assert code == 0, err
    sweep = write(tmp_path)
    code, out, _ = run_main(capsys, "sweep", str(sweep), "--db", str(db), "--dry-run")
    assert code == 0 and out == "cli: 24 scenarios, 0 stored, 24 to run\n"
    err = one_line_error(capsys, "sweep", str(sweep), "--db", str(db), "--task", "tasks:seeded")
    assert "read-only" in err and str(db) in err
    err = one_line_error(capsys, "sweep", str(sweep), "--db", str(read_only_dir / "new.sqlite"),
                         "--task", "tasks:seeded")
    assert str(read_only_dir / "new.sqlite") in err
    assert db.read_bytes() == before
