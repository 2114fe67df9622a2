"""SQLite results store: one row per scenario, keyed by a content hash.

The store is written by the sweep driver only, one transaction per result, in
WAL mode with ``synchronous=NORMAL``: a committed row survives the driver
being killed (even by SIGKILL) and a half-written one never appears. Closing a
writable store switches it back to the rollback journal, so a finished command
leaves no ``-wal`` or ``-shm`` file beside it. The key
is :func:`content_hash` of the scenario's canonical JSON, the package version
and the task that ran it, so re-running a sweep finds its finished rows and a
changed scenario, task or griploop version is a new row.

Tables
------
``results``
    ``hash`` (primary key), ``kind``, ``config`` (canonical JSON), ``task``,
    ``version``, ``status`` (``ok`` or ``failed``), ``result`` (JSON object of
    scalars), ``traces`` (``.npz`` bytes or NULL), ``error``, ``traceback``,
    ``started_at`` / ``finished_at`` (Unix time, s), ``duration_s``, ``worker``,
    ``recorded_at`` (Unix time, s), ``attempts``.
``sweep_members``
    ``(sweep, hash)`` primary key, ``idx`` and ``overrides`` (JSON): which
    scenarios belong to which named sweep.
``claims``
    ``hash``, ``owner`` (``host:pid:token`` of a driver), ``expires_at`` (Unix
    time, s) and ``orphaned``: a scenario being run. A driver claims a
    scenario before running it and the claim goes when its result is
    recorded, so two drivers on one store run each scenario once. A claim
    whose owner died (same host, no such process) or whose lease expired may
    be taken over; ``orphaned`` counts such takeovers, and a scenario orphaned
    twice (its driver died twice while running it) is recorded as failed.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import os
import socket
import sqlite3
import time
import urllib.parse
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from sim.errors import GriploopError

SCHEMA_VERSION = "1"
STATUSES = ("ok", "failed")
EXPORT_FORMATS = ("parquet", "csv")
_BUSY_TIMEOUT_MS = 30_000

_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS results (
    hash TEXT PRIMARY KEY,
    kind TEXT NOT NULL,
    config TEXT NOT NULL,
    task TEXT NOT NULL,
    version TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
    result TEXT,
    traces BLOB,
    error TEXT,
    traceback TEXT,
    started_at REAL,
    finished_at REAL,
    duration_s REAL,
    worker TEXT,
    recorded_at REAL NOT NULL,
    attempts INTEGER NOT NULL DEFAULT 1
);
CREATE TABLE IF NOT EXISTS claims (
    hash TEXT PRIMARY KEY,
    owner TEXT NOT NULL,
    expires_at REAL NOT NULL,
    orphaned INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE IF NOT EXISTS sweep_members (
    sweep TEXT NOT NULL,
    hash TEXT NOT NULL,
    idx INTEGER NOT NULL,
    overrides TEXT NOT NULL,
    PRIMARY KEY (sweep, hash)
);
"""

# Insert a result; a row already 'ok' is never replaced, a 'failed' one is (retries).
_UPSERT = """
INSERT INTO results (hash, kind, config, task, version, status, result, traces, error,
                     traceback, started_at, finished_at, duration_s, worker, recorded_at)
VALUES (:hash, :kind, :config, :task, :version, :status, :result, :traces, :error,
        :traceback, :started_at, :finished_at, :duration_s, :worker, :recorded_at)
ON CONFLICT (hash) DO UPDATE SET
    status = excluded.status, result = excluded.result, traces = excluded.traces,
    error = excluded.error, traceback = excluded.traceback,
    started_at = excluded.started_at, finished_at = excluded.finished_at,
    duration_s = excluded.duration_s, worker = excluded.worker,
    recorded_at = excluded.recorded_at, attempts = results.attempts + 1
WHERE results.status = 'failed'
"""

#: The columns every result row carries besides its config and result (export and rows).
META_COLUMNS = (
    "hash", "kind", "task", "version", "status", "error",
    "started_at", "finished_at", "duration_s", "worker", "attempts",
)  # fmt: skip


class StoreError(GriploopError, ValueError):
    """A results store file is not a griploop store, or a request does not fit it."""


@dataclass(frozen=True)
class Outcome:
    """What running one scenario produced, as the driver records it.

    Attributes
    ----------
    hash : str
        Content hash of the scenario (:func:`content_hash`).
    status : {"ok", "failed"}
        Whether the task returned a valid result.
    result : dict
        Flat mapping of result names to scalars (``ok`` rows; empty otherwise).
    traces : bytes or None
        Optional traces as an ``.npz`` archive (see :func:`encode_traces`).
    error : str or None
        ``"ExceptionType: message"`` of a failed scenario.
    traceback : str or None
        Formatted traceback of a failed scenario.
    started_at, finished_at : float
        Unix time at start and end of the task, s.
    duration_s : float
        Wall time of the task measured with a monotonic clock, s.
    worker : str
        ``host:pid`` of the process that ran it.
    """

    hash: str
    status: str
    result: dict[str, Any]
    traces: bytes | None
    error: str | None
    traceback: str | None
    started_at: float
    finished_at: float
    duration_s: float
    worker: str


def owner_alive(owner: str) -> bool:
    """Whether the driver ``host:pid:token`` may still be running (False only if surely dead)."""
    host, _, rest = owner.partition(":")
    pid_text = rest.partition(":")[0]
    if host != socket.gethostname() or not pid_text.isdigit():
        return True
    try:
        os.kill(int(pid_text), 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def package_version() -> str:
    """Installed version of the ``griploop`` distribution (part of every content hash).

    Raises
    ------
    LookupError
        griploop is not installed (``pip install -e .`` first).
    """
    try:
        return metadata.version("griploop")
    except metadata.PackageNotFoundError:
        raise LookupError(
            "the griploop distribution is not installed (expected `pip install -e .`)"
        ) from None


def content_hash(config_json: str, version: str, task: str) -> str:
    """SHA-256 hex digest of a scenario's canonical JSON, the package version and task name."""
    payload = json.dumps({"config": config_json, "task": task, "version": version})
    return hashlib.sha256(payload.encode()).hexdigest()


def encode_traces(traces: Mapping[str, Any]) -> bytes:
    """Pack named numeric arrays into compressed ``.npz`` bytes."""
    buffer = io.BytesIO()
    arrays = {str(k): np.asarray(v) for k, v in traces.items()}
    for name, arr in arrays.items():
        if arr.dtype.kind not in "biuf":
            raise TypeError(f"trace {name!r} must be numeric (found dtype {arr.dtype})")
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def decode_traces(blob: bytes) -> dict[str, np.ndarray]:
    """Inverse of :func:`encode_traces`."""
    with np.load(io.BytesIO(blob), allow_pickle=False) as archive:
        return {name: archive[name] for name in archive.files}


_SQLITE_MAGIC = b"SQLite format 3\x00"


def _guard(action: str) -> Any:
    """Turn SQLite errors of a store method into one-line StoreErrors naming the file."""

    def wrap(method: Any) -> Any:
        @functools.wraps(method)
        def guarded(self: ResultStore, *args: Any, **kwargs: Any) -> Any:
            try:
                return method(self, *args, **kwargs)
            except sqlite3.Error as exc:
                raise StoreError(_explain(self.path, action, exc)) from None

        return guarded

    return wrap


def _explain(path: Path, action: str, exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    low = text.lower()
    if "disk is full" in low or "disk full" in low:
        hint = "free some space and run again (finished rows are kept)"
    elif "readonly" in low or "read-only" in low:
        hint = "the file or its directory is read-only; export and report can still read it"
    elif "malformed" in low or "not a database" in low or "corrupt" in low:
        hint = "the file is corrupted; restore it from a copy or start a new store"
    elif "unable to open" in low:
        hint = "its directory is read-only, missing or not writable"
    elif "locked" in low or "busy" in low:
        hint = "another process holds the store locked"
    else:
        hint = "expected a readable and writable griploop results store"
    return f"{path}: cannot {action} ({text}); {hint}"


class ResultStore:
    """The SQLite results store of one or more sweeps.

    Parameters
    ----------
    path : str or Path
        Database file; created (with its parent directory) if missing.
    read_only : bool
        Open an existing store for reading only (export, report): nothing is
        written, not even the WAL switch, and read-only media work. A store
        that cannot be opened for writing is opened this way too.

    Raises
    ------
    StoreError
        The file exists but is not a griploop results store (it is then left
        unchanged), is corrupted, or cannot be created.
    FileNotFoundError
        ``read_only`` and no such file.
    """

    def __init__(self, path: str | Path, *, read_only: bool = False) -> None:
        self.path = Path(path)
        self.read_only = read_only
        exists = self.path.exists()
        if exists and not self.path.is_file():
            raise StoreError(f"{self.path}: not a file (expected a griploop results store)")
        if exists:
            self._check_header()
        elif read_only:
            raise FileNotFoundError(
                f"{self.path}: no such results store (expected a file written by griploop sweep)"
            )
        ours = exists and self.path.stat().st_size > 0 and self._identify()
        if read_only:
            if not ours:
                raise StoreError(f"{self.path}: not a griploop results store (found no tables)")
            self._conn = self._open_read_only()
            return
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise StoreError(
                f"{self.path}: cannot create the results store's directory ({exc.strerror})"
            ) from None
        try:
            self._conn = sqlite3.connect(self.path, timeout=_BUSY_TIMEOUT_MS / 1000)
        except sqlite3.Error as exc:
            raise StoreError(_explain(self.path, "create the results store", exc)) from None
        try:
            self._conn.execute("PRAGMA journal_mode=WAL")
            self._conn.execute("PRAGMA synchronous=NORMAL")
            with self._conn:
                self._conn.executescript(_SCHEMA)
                self._conn.execute(
                    "INSERT OR IGNORE INTO meta VALUES ('schema_version', ?)", (SCHEMA_VERSION,)
                )
        except sqlite3.Error as exc:
            self._conn.close()
            low = str(exc).lower()
            if ours and any(k in low for k in ("readonly", "read-only", "unable to open")):
                self.read_only = True  # read-only media: reading still works
                self._conn = self._open_read_only()
                return
            action = "open the results store" if exists else "create the results store"
            raise StoreError(_explain(self.path, action, exc)) from None
        self._check_version()

    def _check_header(self) -> None:
        try:
            with self.path.open("rb") as fh:
                head = fh.read(len(_SQLITE_MAGIC))
        except OSError as exc:
            raise StoreError(
                f"{self.path}: cannot read the results store ({exc.strerror})"
            ) from None
        if head and head != _SQLITE_MAGIC[: len(head)] or 0 < len(head) < len(_SQLITE_MAGIC):
            raise StoreError(
                f"{self.path}: not a griploop results store (expected an SQLite file, "
                "found other data); left unchanged"
            )

    def _open_read_only(self) -> sqlite3.Connection:
        """A read-only connection; on read-only media, an immutable one."""
        uri = "file:" + urllib.parse.quote(str(self.path.resolve()))
        last: sqlite3.Error | None = None
        for query in ("?mode=ro", "?mode=ro&immutable=1"):
            try:
                conn = sqlite3.connect(uri + query, uri=True, timeout=_BUSY_TIMEOUT_MS / 1000)
                conn.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()
                return conn
            except sqlite3.Error as exc:
                last = exc
        raise StoreError(_explain(self.path, "open the results store", last)) from None

    def _identify(self) -> bool:
        """True for a griploop store, False for an empty database; StoreError otherwise."""
        conn = self._open_read_only()
        try:
            tables = sorted(
                r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")
            )
            if not tables:
                return False
            if not {"meta", "results", "sweep_members"} <= set(tables):
                shown = ", ".join(tables[:5]) + (", ..." if len(tables) > 5 else "")
                raise StoreError(
                    f"{self.path}: not a griploop results store (found an SQLite database "
                    f"with tables {shown}); left unchanged"
                )
            self._conn = conn
            self._check_version()
            return True
        except sqlite3.Error as exc:
            raise StoreError(_explain(self.path, "open the results store", exc)) from None
        finally:
            conn.close()

    def _check_version(self) -> None:
        row = self._conn.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()
        found = row[0] if row else None
        if found != SCHEMA_VERSION:
            self._conn.close()
            raise StoreError(
                f"{self.path}: results store schema {found} (expected {SCHEMA_VERSION})"
            )

    def _writable(self, action: str) -> None:
        if self.read_only:
            raise StoreError(
                f"{self.path}: cannot {action}: the store is open read-only "
                "(read-only file or media); export and report can still read it"
            )

    def __enter__(self) -> ResultStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the connection, leaving no ``-wal`` or ``-shm`` file beside the store.

        A writable store returns to the rollback journal as it closes (the WAL is
        checkpointed into the database and removed), so a later read-only open, which
        cannot remove them, creates none. While another process still has the store
        open it keeps the WAL, and the last writer to close removes it.
        """
        if not self.read_only:
            try:
                self._conn.execute("PRAGMA busy_timeout=0")
                self._conn.execute("PRAGMA journal_mode=DELETE")
            except sqlite3.OperationalError:
                pass  # another connection holds the store: it stays in WAL mode for now
        self._conn.close()

    # -------------------------------------------------------------- writing

    @_guard("register the sweep's scenarios")
    def add_members(
        self, sweep: str, members: Iterable[tuple[str, int, Mapping[str, Any]]]
    ) -> None:
        """Register ``(hash, index, overrides)`` of a sweep's scenarios, once each."""
        self._writable("register the sweep's scenarios")
        rows = [(sweep, h, int(i), json.dumps(dict(o), sort_keys=True)) for h, i, o in members]
        with self._conn:
            self._conn.executemany("INSERT OR IGNORE INTO sweep_members VALUES (?, ?, ?, ?)", rows)

    @_guard("record a result")
    def record(self, outcome: Outcome, *, kind: str, config_json: str, task: str,
               version: str) -> bool:
        """Store one outcome and commit.

        A hash already stored as ``ok`` is left unchanged; a ``failed`` one is
        replaced (a retry) and its ``attempts`` counter incremented.

        Returns
        -------
        bool
            Whether the row was inserted or replaced.
        """
        self._writable("record a result")
        if outcome.status not in STATUSES:
            raise StoreError(f"status must be one of {STATUSES} (found {outcome.status!r})")
        params = {
            "hash": outcome.hash,
            "kind": kind,
            "config": config_json,
            "task": task,
            "version": version,
            "status": outcome.status,
            "result": json.dumps(outcome.result, sort_keys=True),
            "traces": outcome.traces,
            "error": outcome.error,
            "traceback": outcome.traceback,
            "started_at": outcome.started_at,
            "finished_at": outcome.finished_at,
            "duration_s": outcome.duration_s,
            "worker": outcome.worker,
            "recorded_at": time.time(),
        }
        with self._conn:
            cursor = self._conn.execute(_UPSERT, params)
            self._conn.execute("DELETE FROM claims WHERE hash = ?", (outcome.hash,))
        return cursor.rowcount == 1

    @_guard("claim a scenario")
    def claim(self, hash_: str, owner: str, lease_s: float, *, retry_failed: bool = False) -> str:
        """Claim one scenario for ``owner`` before running it.

        Returns
        -------
        {"run", "done", "busy", "orphaned"}
            ``run``: claimed, run it. ``done``: already stored (``ok``, or
            ``failed`` without ``retry_failed``). ``busy``: another live
            driver holds an unexpired claim. ``orphaned``: claimed, but its
            driver died twice while running it: record it as failed.
        """
        self._writable("claim a scenario")
        now = time.time()
        with self._conn:
            self._conn.execute("BEGIN IMMEDIATE")
            row = self._conn.execute(
                "SELECT status FROM results WHERE hash = ?", (hash_,)
            ).fetchone()
            if row is not None and (row[0] == "ok" or not retry_failed):
                return "done"
            held = self._conn.execute(
                "SELECT owner, expires_at, orphaned FROM claims WHERE hash = ?", (hash_,)
            ).fetchone()
            orphaned = 0
            if held is not None and held[0] != owner:
                if held[1] > now and owner_alive(held[0]):
                    return "busy"
                orphaned = held[2] + 1
            elif held is not None:
                orphaned = held[2]
            self._conn.execute(
                "INSERT OR REPLACE INTO claims VALUES (?, ?, ?, ?)",
                (hash_, owner, now + lease_s, orphaned),
            )
        return "orphaned" if orphaned >= 2 else "run"

    @_guard("renew claims")
    def renew_claims(self, owner: str, lease_s: float) -> None:
        """Extend every claim of ``owner`` to ``lease_s`` from now."""
        with self._conn:
            self._conn.execute(
                "UPDATE claims SET expires_at = ? WHERE owner = ?", (time.time() + lease_s, owner)
            )

    def release_claims(self, owner: str) -> None:
        """Drop every claim of ``owner`` (a driver stopping cleanly); best effort."""
        try:
            with self._conn:
                self._conn.execute("DELETE FROM claims WHERE owner = ?", (owner,))
        except sqlite3.Error:
            pass  # left claims expire, or are taken over once this process is gone

    # -------------------------------------------------------------- reading

    @_guard("read the results store")
    def statuses(self, hashes: Iterable[str] | None = None) -> dict[str, str]:
        """``{hash: status}`` of stored rows, restricted to ``hashes`` if given."""
        rows = self._conn.execute("SELECT hash, status FROM results").fetchall()
        found = dict(rows)
        if hashes is None:
            return found
        return {h: found[h] for h in hashes if h in found}

    @_guard("read the results store")
    def counts(self, sweep: str | None = None) -> dict[str, int]:
        """Number of rows per status (``{"ok": n, "failed": m}``), optionally of one sweep."""
        sql, args = "SELECT status, COUNT(*) FROM results", ()
        if sweep is not None:
            sql += " WHERE hash IN (SELECT hash FROM sweep_members WHERE sweep = ?)"
            args = (sweep,)
        found = dict(self._conn.execute(sql + " GROUP BY status", args).fetchall())
        return {s: int(found.get(s, 0)) for s in STATUSES}

    @_guard("read the results store")
    def sweeps(self) -> list[str]:
        """Names of the sweeps registered in the store."""
        rows = self._conn.execute("SELECT DISTINCT sweep FROM sweep_members ORDER BY sweep")
        return [r[0] for r in rows]

    @_guard("read the results store")
    def rows(self, *, sweep: str | None = None, status: str | None = None) -> list[dict[str, Any]]:
        """Stored rows with ``config`` and ``result`` parsed, ordered by sweep index then hash.

        Parameters
        ----------
        sweep : str, optional
            Only rows of this sweep (adds ``sweep``, ``idx`` and ``overrides``).
        status : {"ok", "failed"}, optional
            Only rows with this status.

        Raises
        ------
        StoreError
            Unknown sweep name or status.
        """
        if status is not None and status not in STATUSES:
            raise StoreError(f"status must be one of {STATUSES} (found {status!r})")
        if sweep is not None and sweep not in self.sweeps():
            found = ", ".join(self.sweeps()) or "none"
            raise StoreError(f"{self.path}: no sweep named {sweep!r} (found: {found})")
        cols = ", ".join(f"r.{c}" for c in (*META_COLUMNS, "config", "result", "traceback"))
        if sweep is None:
            sql = f"SELECT {cols}, NULL, NULL, NULL FROM results r WHERE 1"
            args: list[Any] = []
        else:
            sql = (
                f"SELECT {cols}, m.sweep, m.idx, m.overrides FROM results r "
                "JOIN sweep_members m ON m.hash = r.hash WHERE m.sweep = ?"
            )
            args = [sweep]
        if status is not None:
            sql += " AND r.status = ?"
            args.append(status)
        sql += " ORDER BY " + ("m.idx, r.hash" if sweep is not None else "r.recorded_at, r.hash")
        names = (*META_COLUMNS, "config", "result", "traceback", "sweep", "idx", "overrides")
        out = []
        for values in self._conn.execute(sql, args):
            row = dict(zip(names, values, strict=True))
            row["config"] = json.loads(row["config"])
            row["result"] = json.loads(row["result"]) if row["result"] else {}
            row["overrides"] = json.loads(row["overrides"]) if row["overrides"] else None
            out.append(row)
        return out

    @_guard("read traces")
    def traces(self, hash_: str) -> dict[str, np.ndarray]:
        """Traces stored with one scenario (empty if it stored none).

        Raises
        ------
        StoreError
            No row with this hash.
        """
        row = self._conn.execute("SELECT traces FROM results WHERE hash = ?", (hash_,)).fetchone()
        if row is None:
            raise StoreError(f"{self.path}: no result with hash {hash_!r}")
        return decode_traces(row[0]) if row[0] is not None else {}
