"""Results store: keys, upsert semantics, traces, persistence and export."""

from __future__ import annotations

import hashlib
import json
import sqlite3

import numpy as np
import pyarrow.csv as pa_csv
import pyarrow.parquet as pq
import pytest

from scenarios.export import export_store
from scenarios.schema import Scenario
from scenarios.store import (
    Outcome,
    ResultStore,
    StoreError,
    content_hash,
    decode_traces,
    encode_traces,
    package_version,
)

VERSION = "9.9.9"
TASK = "tasks:seeded"


def scenario(mass_kg: float = 0.2, seed: int = 1) -> Scenario:
    return Scenario.model_validate({"object": {"mass_kg": mass_kg}, "seed": seed})


def outcome(sc: Scenario, status: str = "ok", **result) -> Outcome:
    return Outcome(
        hash=content_hash(sc.canonical_json(), VERSION, TASK),
        status=status,
        result=result if status == "ok" else {},
        traces=None,
        error=None if status == "ok" else "ValueError: boom",
        traceback=None if status == "ok" else "Traceback ...\nValueError: boom\n",
        started_at=100.0,
        finished_at=100.5,
        duration_s=0.5,
        worker="host:1",
    )


def record(store: ResultStore, sc: Scenario, out: Outcome) -> bool:
    return store.record(out, kind=sc.kind, config_json=sc.canonical_json(), task=TASK,
                        version=VERSION)


def test_content_hash_is_sha256_of_config_version_and_task():
    config = Scenario().canonical_json()
    payload = json.dumps({"config": config, "task": TASK, "version": VERSION})
    assert content_hash(config, VERSION, TASK) == hashlib.sha256(payload.encode()).hexdigest()
    assert content_hash(config, "0.0.1", TASK) != content_hash(config, VERSION, TASK)
    assert content_hash(config, VERSION, "tasks:sleepy") != content_hash(config, VERSION, TASK)


def test_package_version_is_the_installed_distribution():
    from importlib.metadata import version

    assert package_version() == version("griploop")


def test_store_uses_wal_while_open_and_survives_reopen(tmp_path):
    path = tmp_path / "r.sqlite"
    sc = scenario()
    with ResultStore(path) as store:
        assert record(store, sc, outcome(sc, r2=0.9))
        with sqlite3.connect(path) as conn:
            assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    with ResultStore(path) as store:
        (row,) = store.rows()
    assert row["status"] == "ok" and row["result"] == {"r2": 0.9}
    assert row["config"] == json.loads(sc.canonical_json())
    assert row["duration_s"] == 0.5 and row["attempts"] == 1


def test_ok_row_is_never_duplicated_nor_overwritten(tmp_path):
    sc = scenario()
    with ResultStore(tmp_path / "r.sqlite") as store:
        assert record(store, sc, outcome(sc, r2=0.9))
        assert not record(store, sc, outcome(sc, r2=0.1))
        assert not record(store, sc, outcome(sc, "failed"))
        rows = store.rows()
    assert len(rows) == 1 and rows[0]["result"] == {"r2": 0.9}


def test_failed_row_is_replaced_by_a_retry(tmp_path):
    sc = scenario()
    with ResultStore(tmp_path / "r.sqlite") as store:
        record(store, sc, outcome(sc, "failed"))
        assert store.counts() == {"ok": 0, "failed": 1}
        assert record(store, sc, outcome(sc, r2=0.8))
        (row,) = store.rows()
    assert row["status"] == "ok" and row["error"] is None and row["attempts"] == 2


def test_traces_round_trip_bit_exactly(tmp_path):
    rng = np.random.default_rng(0)
    traces = {"force_n": rng.standard_normal((100, 2)), "slip": np.arange(5, dtype=np.int8)}
    assert set(decode_traces(encode_traces(traces))) == {"force_n", "slip"}
    sc = scenario()
    out = outcome(sc, r2=1.0)
    out = Outcome(**{**out.__dict__, "traces": encode_traces(traces)})
    with ResultStore(tmp_path / "r.sqlite") as store:
        record(store, sc, out)
        back = store.traces(out.hash)
        with pytest.raises(StoreError, match="no result with hash"):
            store.traces("0" * 64)
    np.testing.assert_array_equal(back["force_n"], traces["force_n"])
    assert back["slip"].dtype == np.int8


def test_non_numeric_traces_are_rejected():
    with pytest.raises(TypeError, match="must be numeric"):
        encode_traces({"labels": np.array(["a", "b"])})


def test_not_a_store_is_a_store_error(tmp_path):
    path = tmp_path / "bogus.sqlite"
    path.write_bytes(b"this is not sqlite at all" * 100)
    with pytest.raises(StoreError, match="not a griploop results store"):
        ResultStore(path)


def test_members_and_sweep_filter(tmp_path):
    a, b, c = scenario(0.1), scenario(0.2), scenario(1.5)
    oa, ob, oc = outcome(a, r2=0.1), outcome(b, r2=0.2), outcome(c, "failed")
    with ResultStore(tmp_path / "r.sqlite") as store:
        store.add_members("first", [(ob.hash, 1, {"object.mass_kg": 0.2}),
                                    (oa.hash, 0, {"object.mass_kg": 0.1})])
        store.add_members("first", [(oa.hash, 0, {"object.mass_kg": 0.1})])  # idempotent
        store.add_members("second", [(oc.hash, 0, {})])
        for sc, out in ((a, oa), (b, ob), (c, oc)):
            record(store, sc, out)
        assert store.sweeps() == ["first", "second"]
        first = store.rows(sweep="first")
        assert [r["idx"] for r in first] == [0, 1]
        assert first[0]["overrides"] == {"object.mass_kg": 0.1}
        assert store.counts("first") == {"ok": 2, "failed": 0}
        assert store.counts() == {"ok": 2, "failed": 1}
        assert [r["hash"] for r in store.rows(status="failed")] == [oc.hash]
        with pytest.raises(StoreError, match="no sweep named 'third'"):
            store.rows(sweep="third")
        with pytest.raises(StoreError, match="status must be one of"):
            store.rows(status="done")


def test_export_parquet_and_csv_hold_the_same_flat_table(tmp_path):
    a, b, c = scenario(0.1, seed=1), scenario(0.4, seed=2), scenario(1.5, seed=3)
    with ResultStore(tmp_path / "r.sqlite") as store:
        record(store, a, outcome(a, r2=0.91, n_slips=0, note="fine", flag=True))
        record(store, b, outcome(b, r2=0.5, n_slips=2, note=3.5, flag=False))
        record(store, c, outcome(c, "failed"))
        written = export_store(store, tmp_path / "out" / "table")
        with pytest.raises(StoreError, match="export formats"):
            export_store(store, tmp_path / "x", ["xlsx"])
    assert [p.name for p in written] == ["table.parquet", "table.csv"]
    table = pq.read_table(written[0])
    assert table.num_rows == 3
    cols = table.to_pydict()
    assert cols["config.object.mass_kg"] == [0.1, 0.4, 1.5]
    assert cols["config.seed"] == [1, 2, 3]
    assert cols["result.r2"] == [0.91, 0.5, None]
    assert cols["result.n_slips"] == [0, 2, None]
    assert cols["result.flag"] == [True, False, None]
    assert cols["result.note"] == ['"fine"', "3.5", None]  # mixed types -> JSON text
    assert cols["status"] == ["ok", "ok", "failed"]
    assert cols["error"][2] == "ValueError: boom"
    assert str(table.schema.field("result.n_slips").type) == "int64"
    csv = pa_csv.read_csv(written[1]).to_pydict()
    assert csv["config.object.mass_kg"] == cols["config.object.mass_kg"]
    assert csv["result.r2"] == cols["result.r2"]
    assert csv["hash"] == cols["hash"]


def test_export_of_one_status_only(tmp_path):
    a, c = scenario(0.1), scenario(1.5)
    with ResultStore(tmp_path / "r.sqlite") as store:
        record(store, a, outcome(a, r2=0.9))
        record(store, c, outcome(c, "failed"))
        (path,) = export_store(store, tmp_path / "ok", ["csv"], status="ok")
    assert pa_csv.read_csv(path).num_rows == 1


def leftovers(directory) -> list[str]:
    return sorted(p.name for p in directory.iterdir() if p.name.endswith(("-wal", "-shm")))


def test_closing_leaves_no_wal_or_shm_even_after_a_read_only_open(tmp_path):
    path = tmp_path / "r.sqlite"
    sc = scenario()
    with ResultStore(path) as store:
        assert record(store, sc, outcome(sc, r2=0.9))
    assert leftovers(tmp_path) == []
    with ResultStore(path, read_only=True) as store:  # what report and export do
        assert len(store.rows()) == 1
    assert leftovers(tmp_path) == []


def test_a_second_writer_keeps_the_wal_until_the_last_one_closes(tmp_path):
    path = tmp_path / "r.sqlite"
    first, second = ResultStore(path), ResultStore(path)
    sc = scenario()
    assert record(second, sc, outcome(sc, r2=0.5))
    first.close()  # does not wait for the other writer, nor disturb it
    assert record(second, scenario(mass_kg=0.4), outcome(scenario(mass_kg=0.4), r2=0.6))
    second.close()
    assert leftovers(tmp_path) == []
    with ResultStore(path, read_only=True) as store:
        assert len(store.rows()) == 2
