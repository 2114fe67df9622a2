"""sim.cache.cached: read, lock, read again, build once, write; an unwritable cache warns once."""

from __future__ import annotations

import json
import warnings

import pytest

from sim import cache as sim_cache
from sim.cache import CacheNotWritableWarning, cached


def _read(path):
    try:
        return json.loads(path.read_text())["value"]
    except (OSError, ValueError, KeyError):
        return None


def _write(path, value):
    sim_cache.write_atomic(path, json.dumps({"value": value}).encode())


class Builds:
    """A build that counts its calls."""

    def __init__(self, value: int = 7) -> None:
        self.value, self.calls = value, 0

    def __call__(self) -> int:
        self.calls += 1
        return self.value


def test_an_entry_is_built_once_then_read(tmp_path):
    path = tmp_path / "entries" / "a.json"
    build = Builds()
    assert cached(path, _read, build, _write) == (7, "built")
    assert cached(path, _read, build, _write) == (7, "disk")
    assert build.calls == 1 and _read(path) == 7
    assert not list(path.parent.glob(".tmp-*"))  # written atomically, nothing left behind


def test_an_entry_another_process_stored_meanwhile_is_read_not_built(tmp_path):
    # the first read misses; while this process waits for the lock another one stores
    # the entry: the read under the lock finds it
    path = tmp_path / "b.json"
    reads = []

    def read(p):
        reads.append(p)
        if len(reads) == 1:
            _write(p, 11)  # the other process, done before the lock is ours
            return None
        return _read(p)

    build = Builds()
    assert cached(path, read, build, _write) == (11, "disk")
    assert build.calls == 0 and len(reads) == 2


def test_a_corrupted_entry_is_rebuilt_and_replaced(tmp_path):
    path = tmp_path / "c.json"
    path.write_text("{not json")
    assert cached(path, _read, Builds(3), _write) == (3, "built")
    assert _read(path) == 3


def test_cache_off_builds_and_writes_nothing(tmp_path):
    build = Builds()
    assert cached(None, _read, build, _write) == (7, "built (cache off)")
    assert cached(None, _read, build, _write) == (7, "built (cache off)")
    assert build.calls == 2


def test_a_writer_may_say_why_it_stored_nothing(tmp_path):
    path = tmp_path / "d.json"
    assert cached(path, _read, Builds(), lambda p, v: "built (not storable)") == (
        7, "built (not storable)")
    assert not path.exists()


def test_an_unwritable_directory_warns_once_and_returns_what_was_built(tmp_path):
    blocker = tmp_path / "a_file"  # a directory under a regular file cannot be made
    blocker.write_text("x")        # (as root too, unlike a read-only directory)
    build = Builds()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert cached(blocker / "c" / "e.json", _read, build, _write) == (
            7, "built (cache not writable)")
        assert cached(blocker / "c" / "f.json", _read, build, _write) == (
            7, "built (cache not writable)")
        sim_cache.warn_not_writable(blocker / "c", OSError("again"))
    said = [w for w in caught if issubclass(w.category, CacheNotWritableWarning)]
    assert len(said) == 1 and str(blocker / "c") in str(said[0].message)
    assert build.calls == 2
    with pytest.warns(CacheNotWritableWarning):  # another directory: said again
        cached(blocker / "d" / "e.json", _read, build, _write)
