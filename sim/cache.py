"""Where griploop keeps what it computes once and reuses: one root, atomic writes.

Every disk cache (plant families, controller designs, pretrained estimators) lives under
``$GRIPLOOP_CACHE_DIR`` (default ``~/.cache/griploop``), one subdirectory each;
``GRIPLOOP_CACHE_DIR=off`` disables them all. Caches hold arrays (NPZ) and JSON.
"""

from __future__ import annotations

import os
import tempfile
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
