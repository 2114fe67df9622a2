"""The on-disk plant-family cache returns exactly what a fresh build gives."""

import warnings

import numpy as np
import pytest

from controllers import plant_cache
from controllers.design_plant import plant_family
from sim.cache import CacheNotWritableWarning
from sim.hand.objects import make_object

CAN = make_object("can", mass_kg=0.3, friction=0.7)
GRID = (3.0, 10.0)


def _build(obj=CAN, grid=GRID):
    return lambda: plant_family(obj, control_dt_s=0.01, forces_n=grid)


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))
    return tmp_path / "plants"


def test_a_cached_family_equals_a_fresh_one(cache):
    fresh, source = plant_cache.cached_family(CAN, 0.01, GRID, _build())
    assert source == "built" and len(list(cache.glob("*.npz"))) == 1
    again, source = plant_cache.cached_family(CAN, 0.01, GRID, _build())
    assert source == "disk"
    for a, b in zip(fresh.points, again.points, strict=True):
        assert (a.force_n, a.how, a.notes, a.reason) == (b.force_n, b.how, b.notes, b.reason)
        for name in ("A", "B", "C", "D"):
            np.testing.assert_array_equal(getattr(a.plant.model, name),
                                          getattr(b.plant.model, name))
        assert a.plant.model.dt == b.plant.model.dt
        assert (a.plant.u0, a.plant.y0_n, a.plant.method) == (b.plant.u0, b.plant.y0_n,
                                                             b.plant.method)
        assert b.plant.object is CAN


def test_the_key_follows_object_period_and_grid():
    key = plant_cache.family_key(CAN, 0.01, GRID)
    assert key == plant_cache.family_key(CAN, 0.01, GRID)
    assert key != plant_cache.family_key(CAN.replace(mass_kg=0.31), 0.01, GRID)
    assert key != plant_cache.family_key(CAN, 0.02, GRID)
    assert key != plant_cache.family_key(CAN, 0.01, (3.0, 10.0, 20.0))


def test_a_corrupted_file_is_rebuilt_and_replaced(cache):
    plant_cache.cached_family(CAN, 0.01, GRID, _build())
    (path,) = cache.glob("*.npz")
    path.write_bytes(b"not an npz")
    family, source = plant_cache.cached_family(CAN, 0.01, GRID, _build())
    assert source == "built" and family.points[0].ok
    assert plant_cache.cached_family(CAN, 0.01, GRID, _build())[1] == "disk"


def test_cache_off_and_not_writable(tmp_path, monkeypatch):
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", "off")
    assert plant_cache.cached_family(CAN, 0.01, GRID, _build())[1] == "built (cache off)"
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(blocker))  # its "plants" cannot be made
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for grid in (GRID, (3.0,)):
            family, source = plant_cache.cached_family(CAN, 0.01, grid, _build(grid=grid))
            assert source == "built (cache not writable)" and family.points[0].ok
    said = [w for w in caught if issubclass(w.category, CacheNotWritableWarning)]
    assert len(said) == 1 and "plants" in str(said[0].message)  # once per directory


def _race(cache_root: str, marks: str, go, out) -> None:
    """One sweep worker: miss the family, build it (slowly, leaving a mark), report the source."""
    import os
    import time

    os.environ["GRIPLOOP_CACHE_DIR"] = cache_root
    build = _build()

    def slow_build():
        with open(marks, "a") as f:
            f.write(f"{os.getpid()}\n")
        time.sleep(0.5)  # the other worker misses meanwhile
        return build()

    go.wait()
    out.put(plant_cache.cached_family(CAN, 0.01, GRID, slow_build)[1])


def test_two_workers_missing_one_family_build_it_once(tmp_path):
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    go, out, marks = ctx.Event(), ctx.Queue(), tmp_path / "builds.txt"
    workers = [ctx.Process(target=_race, args=(str(tmp_path / "c"), str(marks), go, out))
               for _ in range(2)]
    for w in workers:
        w.start()
    go.set()
    sources = sorted(out.get(timeout=60) for _ in workers)
    for w in workers:
        w.join(timeout=60)
    assert sources == ["built", "disk"]  # the second waited for the first's file
    assert len(marks.read_text().split()) == 1
