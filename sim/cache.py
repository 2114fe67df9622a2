"""Where griploop keeps what it computes once and reuses: one root, atomic writes.

Every disk cache (plant families, controller designs, pretrained estimators) lives under
``$GRIPLOOP_CACHE_DIR`` (default ``~/.cache/griploop``), one subdirectory each;
``GRIPLOOP_CACHE_DIR=off`` disables them all. Caches hold arrays (NPZ) and JSON.
Writes are atomic (:func:`write_atomic`); :func:`build_lock` lets one process build an entry
while the others that want the same one wait and then read it, instead of building it too.
:func:`cached` is that read, lock, read again, build and write, for every cache. A cache
directory that cannot be written is not an error: the command goes on uncached, and a
:class:`CacheNotWritableWarning` says so once per directory and process.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import os
import sys
import tempfile
import warnings
from collections.abc import Callable, Iterable, Iterator
from importlib import metadata
from pathlib import Path
from typing import TypeVar

from sim.errors import GriploopError

_OFF = ("off", "0", "none")
_T = TypeVar("_T")


class CacheNotWritableWarning(GriploopError, UserWarning):
    """A cache directory cannot be written: what was built is returned, not stored.

    Issued once per directory and process (:func:`warn_not_writable`).
    """


_WARNED: set[str] = set()


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


#: Files of a package whose content a cached result depends on.
_SOURCE_SUFFIXES = (".py", ".xml")


def source_digest(packages: Iterable[str], modules: Iterable[str] = (),
                  distributions: Iterable[str] = ("griploop",)) -> str:
    """SHA-256 of the source a cached result is computed by.

    Every ``.py`` and ``.xml`` file under each package (found by walking its
    directory, so a new module counts without being listed), the file of each
    further module (e.g. a plugin's, already imported), and the installed
    versions of ``distributions``.

    Parameters
    ----------
    packages : iterable of str
        Dotted package names (``"controllers"``, ``"sim.hand"``).
    modules : iterable of str
        Modules outside those packages; one that is not imported, or has no
        file, counts by its name only.
    distributions : iterable of str
        Distributions whose version counts (``"source"`` when not installed).
    """
    h = hashlib.sha256()
    for package in packages:
        spec = importlib.util.find_spec(package)
        roots = list(spec.submodule_search_locations or []) if spec else []
        for root in map(Path, roots):
            for path in sorted(p for p in root.rglob("*") if p.suffix in _SOURCE_SUFFIXES
                               and "__pycache__" not in p.parts):
                h.update(f"{package}/{path.relative_to(root).as_posix()}\n".encode())
                h.update(path.read_bytes())
    for name in modules:
        h.update(f"module {name}\n".encode())
        file = getattr(sys.modules.get(name), "__file__", None)
        if file and Path(file).is_file():
            h.update(Path(file).read_bytes())
    for dist in distributions:
        try:
            h.update(f"{dist} {metadata.version(dist)}\n".encode())
        except metadata.PackageNotFoundError:  # running from a source tree
            h.update(f"{dist} source\n".encode())
    return h.hexdigest()


@contextlib.contextmanager
def build_lock(path: Path) -> Iterator[bool]:
    """Hold an exclusive lock on ``path`` + ``.lock`` while the entry ``path`` is built.

    Processes that want the same entry (sweep workers, parallel test workers) call this
    around check-then-build: the first builds, the others block until it is done and then
    find the entry on disk, so no two build the same thing. The lock is an advisory
    ``flock`` on a small file beside the entry, released when the block ends or the
    process dies (never left stale). Yields whether the lock is held: False where the
    directory cannot be written or the platform has no ``fcntl`` (the caller then builds
    unlocked).
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


def warn_not_writable(directory: Path, exc: OSError) -> None:
    """Warn (:class:`CacheNotWritableWarning`) that ``directory`` cannot be written.

    Once per directory and process: the next entries of an unwritable cache say nothing.
    """
    if str(directory) in _WARNED:
        return
    _WARNED.add(str(directory))
    warnings.warn(f"cache directory {directory} cannot be written ({exc}); going on "
                  "without caching there", CacheNotWritableWarning, stacklevel=3)


def cached(path: Path | None, read: Callable[[Path], _T | None], build: Callable[[], _T],
           write: Callable[[Path, _T], str | None]) -> tuple[_T, str]:
    """The entry at ``path`` from the cache, or ``build()`` it and store it there.

    Reads ``path``; on a miss, takes :func:`build_lock` and reads again (another process
    may have built the entry meanwhile), then builds and writes it. A directory that
    cannot be written is warned about (:func:`warn_not_writable`) and the built value
    returned all the same.

    Parameters
    ----------
    path : Path or None
        Where the entry lives; None when caching is off (``build()`` only).
    read : callable
        ``read(path) -> value``, or None for a miss (missing, corrupted, stale, foreign).
    build : callable
        ``build() -> value``, called at most once.
    write : callable
        ``write(path, value)``, raising ``OSError`` when it cannot write; it may return a
        status in place of ``"built"`` (e.g. why the value was not stored).

    Returns
    -------
    value : object
    source : str
        ``"disk"``, ``"built"``, ``"built (cache off)"``, ``"built (cache not writable)"``
        or the status ``write`` returned.
    """
    if path is None:
        return build(), "built (cache off)"
    found = read(path)
    if found is not None:
        return found, "disk"
    with build_lock(path):  # another process building it: wait, then read its entry
        found = read(path)
        if found is not None:
            return found, "disk"
        value = build()
        try:
            status = write(path, value)
        except OSError as exc:
            warn_not_writable(path.parent, exc)
            return value, "built (cache not writable)"
    return value, status or "built"
