"""Where griploop keeps what it computes once and reuses: one root, atomic writes.

Every disk cache (plant families, controller designs, pretrained estimators) lives under
``$GRIPLOOP_CACHE_DIR`` (default ``~/.cache/griploop``), one subdirectory each;
``GRIPLOOP_CACHE_DIR=off`` disables them all. Caches hold arrays (NPZ) and JSON.
Writes are atomic (:func:`write_atomic`); :func:`build_lock` lets one process build an entry
while the others that want the same one wait and then read it, instead of building it too.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

_OFF = ("off", "0", "none")


def cache_root() -> Path | None:
    """The cache root, or None when disabled (``GRIPLOOP_CACHE_DIR=off``)."""
    root = os.environ.get("GRIPLOOP_CACHE_DIR", "")
    if root.lower() in _OFF:
        return None
    return Path(root) if root else Path.home() / ".cache" / "griploop"


def cache_subdir(name: str) -> Path | None:
    """``cache_root() / name``, or None when caching is disabled."""
    root = cache_root()
    return None if root is None else root / name


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file renamed into place.

    Concurrent readers (other sweep workers) see the old file or the new one,
    never half of one. Creates the directory if needed.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def build_lock(path: Path) -> Iterator[bool]:
    """Hold an exclusive lock on ``path`` + ``.lock`` while the entry ``path`` is built.

    Processes that want the same entry (sweep workers, parallel test workers) call this
    around check-then-build: the first builds, the others block until it is done and then
    find the entry on disk. The lock is an advisory ``flock`` on a small file beside the
    entry, released when the block ends or the process dies (never left stale). Yields
    whether the lock is held: False where the directory cannot be written or the platform
    has no ``fcntl`` (the caller then builds unlocked, as without this helper).
    """
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock, each process builds
        yield False
        return
    lock_path = path.with_name(path.name + ".lock")
    try:
        lock_path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o600)
    except OSError:
        yield False
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield True
    finally:
        os.close(fd)  # closing the descriptor releases the lock
