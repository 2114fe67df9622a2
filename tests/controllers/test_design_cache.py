"""The on-disk design cache gives what a fresh design gives and trusts no broken file."""

import warnings

import numpy as np
import pytest

from controllers import design_cache
from controllers.base import Observation
from controllers.design import controller_map, design_for_object
from controllers.design_spec import DesignSpec
from sim.cache import CacheNotWritableWarning
from sim.hand.objects import make_object

CAN = make_object("can", mass_kg=0.3, friction=0.7)
GRID = (3.0, 10.0)
SPEC = {"phase_margin_deg": 60.0, "crossover_rad_s": 30.0}


def _build(obj=CAN, kind="pid", spec=SPEC, grid=GRID):
    spec = DesignSpec.from_mapping({**spec, "forces_n": grid})
    return lambda: design_for_object(obj, kind, spec, control_dt_s=0.01)


def _cached(obj=CAN, kind="pid", spec=SPEC, grid=GRID):
    return design_cache.cached_design(obj, kind, 0.01, spec, grid, _build(obj, kind, spec, grid))


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(tmp_path))
    return tmp_path / "designs"


def _commands(design, n=120):
    """The controller's commands over a closing-contact-hold sequence of observations."""
    ctl = design.controller
    ctl.reset()
    out = []
    for k in range(n):
        touching = k >= 20
        grip = 0.0 if not touching else 4.0 + 2.0 * np.sin(0.1 * k)
        out.append(ctl.act(Observation(time_s=0.01 * k, reference_n=6.0, grip_force_n=grip,
                                       thumb_contact=touching, finger_contact=touching,
                                       load_force_n=2.0 if k > 60 else 0.0)))
    return np.array(out, dtype=float)


def _assert_same_system(a, b):
    for name in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert a.dt == b.dt


@pytest.mark.parametrize("kind,spec", [("pid", SPEC), ("lead_lag", SPEC),
                                       ("mpc", {"horizon": 10})])
def test_a_cached_design_equals_a_fresh_one(cache, kind, spec):
    fresh, source = _cached(kind=kind, spec=spec)
    assert source == "built" and len(list(cache.glob("*.design"))) == 1
    again, source = _cached(kind=kind, spec=spec)
    assert source == "disk" and again is not fresh
    assert (again.kind, again.spec, again.notes, again.scheduled) == (
        fresh.kind, fresh.spec, fresh.notes, fresh.scheduled)
    assert again.design_forces_n == fresh.design_forces_n
    for a, b in zip(fresh.core.designs, again.core.designs, strict=True):
        _assert_same_system(controller_map(a), controller_map(b))  # gains and matrices
    for a, b in zip(fresh.family.points, again.family.points, strict=True):
        _assert_same_system(a.plant.model, b.plant.model)
    np.testing.assert_array_equal(_commands(fresh), _commands(again))
    # margins: analysed by the first process, read back by the next one
    force = 5.0
    made = fresh.analyse(force)
    loaded = _cached(kind=kind, spec=spec)[0]
    assert force in loaded._cache
    stored = loaded.analyse(force)
    assert stored.margins.to_dict() == made.margins.to_dict()
    _assert_same_system(stored.margins.loop, made.margins.loop)
    _assert_same_system(stored.controller, made.controller)
    # and equal to an analysis made from scratch on a fresh design
    scratch = _build(kind=kind, spec=spec)().analyse(force)
    assert scratch.margins.to_dict() == stored.margins.to_dict()


@pytest.mark.parametrize("kind,spec", [("pid", SPEC), ("mpc", {"horizon": 10})])
def test_a_new_process_reads_the_design_another_one_stored(cache, kind, spec):
    """A process that has not imported the kind's module yet still reads the file.

    (It used to refuse griploop's own classes of modules not yet imported, so every
    new ``griploop episode`` process designed again.)
    """
    import subprocess
    import sys
    from pathlib import Path

    _cached(kind=kind, spec=spec)
    code = ("import sys\n"
            "from controllers import design_cache\n"
            "from sim.hand.objects import make_object\n"
            f"module = {design_cache.design_modules(kind)[0]!r}\n"
            "before = module in sys.modules\n"
            "obj = make_object('can', mass_kg=0.3, friction=0.7)\n"
            f"_, source = design_cache.cached_design(obj, {kind!r}, 0.01, {spec!r}, "
            f"{GRID!r}, lambda: 1 / 0)\n"
            "print(before, source)\n")
    root = Path(__file__).resolve().parents[2]
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=root, timeout=300,
                         env={**__import__("os").environ, "PYTHONPATH": str(root),
                              "GRIPLOOP_CACHE_DIR": str(cache.parent)})
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "disk"]


def test_analyses_of_many_forces_are_written_once_and_read_back(cache, monkeypatch):
    design, _ = _cached()
    writes = []
    real = design_cache.write_atomic
    monkeypatch.setattr(design_cache, "write_atomic",
                        lambda path, data: (writes.append(path), real(path, data)))
    made = design.analyse_many([4.0, 6.0, 8.0])
    assert [p.suffix for p in writes] == [".analyses"]  # one write for three analyses
    design.analyse(9.0)  # one at a time: written through at once
    assert len(writes) == 2
    loaded, source = _cached()
    assert source == "disk" and {4.0, 6.0, 8.0, 9.0} <= set(loaded._cache)
    for a, f in zip(made, (4.0, 6.0, 8.0), strict=True):
        assert loaded.analyse(f).margins.to_dict() == a.margins.to_dict()


def test_the_key_follows_object_kind_period_spec_and_grid():
    key = design_cache.design_key(CAN, "pid", 0.01, SPEC, GRID)
    assert key == design_cache.design_key(CAN, "pid", 0.01, dict(SPEC), GRID)
    assert key != design_cache.design_key(CAN.replace(friction=0.71), "pid", 0.01, SPEC, GRID)
    assert key != design_cache.design_key(CAN, "lead_lag", 0.01, SPEC, GRID)
    assert key != design_cache.design_key(CAN, "pid", 0.005, SPEC, GRID)
    assert key != design_cache.design_key(CAN, "pid", 0.01, {**SPEC, "phase_margin_deg": 50.0},
                                          GRID)
    assert key != design_cache.design_key(CAN, "pid", 0.01,
                                          {**SPEC, "slip_reflex": {"gain": 1.0}}, GRID)
    assert key != design_cache.design_key(CAN, "pid", 0.01, SPEC, (3.0, 10.0, 20.0))


def test_a_changed_spec_or_object_misses(cache):
    assert _cached()[1] == "built"
    assert _cached(spec={**SPEC, "crossover_rad_s": 20.0})[1] == "built"
    assert _cached(obj=CAN.replace(mass_kg=0.5))[1] == "built"
    assert _cached()[1] == "disk"
    assert len(list(cache.glob("*.design"))) == 3


@pytest.mark.parametrize("damage", ["garbage", "truncated", "tampered", "other_key"])
def test_a_broken_file_is_rebuilt_not_trusted(cache, damage):
    fresh, _ = _cached()
    fresh.analyse(5.0)
    (path,) = cache.glob("*.design")
    data = path.read_bytes()
    if damage == "garbage":
        data = b"not a design"
    elif damage == "truncated":
        data = data[: len(data) // 2]
    elif damage == "tampered":  # valid header, payload changed: the digest no longer matches
        data = data[:-8] + b"\x00" * 8
    else:  # a valid file of another design copied over this one
        other = design_cache.design_key(CAN, "lead_lag", 0.01, SPEC, GRID)
        data = design_cache.dumps(fresh, other)
    path.write_bytes(data)
    (analyses,) = cache.glob("*.analyses")
    analyses.write_bytes(b"\x80\x05junk")
    design, source = _cached()
    assert source == "built"
    assert design._cache == {}  # the broken analyses were not read
    np.testing.assert_array_equal(_commands(design), _commands(fresh))
    assert _cached()[1] == "disk"  # and the file was replaced by a good one


def test_cache_off(monkeypatch):
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", "off")
    design, source = _cached()
    assert source == "built (cache off)" and design.controller is not None


def test_an_unwritable_cache_warns_once_and_the_design_is_still_made(tmp_path, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    monkeypatch.setenv("GRIPLOOP_CACHE_DIR", str(blocker))  # its "designs" cannot be made
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(2):
            design, source = _cached()
            assert source == "built (cache not writable)" and design.controller is not None
            design.analyse(6.0)  # written through: not stored either, and said no more
    said = [str(w.message) for w in caught if issubclass(w.category, CacheNotWritableWarning)]
    assert len([m for m in said if "designs" in m]) == 1, said


def test_a_file_that_names_a_foreign_class_is_a_miss_and_builds_nothing(cache, monkeypatch):
    import io
    import json
    import os

    _cached()
    (path,) = cache.glob("*.design")
    key = design_cache.design_key(CAN, "pid", 0.01, SPEC, GRID)
    called = []
    monkeypatch.setattr(os, "system", lambda *a: called.append(a))
    buffer = io.BytesIO()  # well formed, right key, asks for os.system
    tree = {"layout": [], "value": {"$object": "os:system", "id": 0, "state": {}}}
    np.savez(buffer, key=np.array(f"{design_cache.FORMAT} {key}"),
             tree=np.frombuffer(json.dumps(tree).encode(), np.uint8),
             blob=np.zeros(0, np.uint8))
    path.write_bytes(buffer.getvalue())
    with pytest.raises(ValueError, match="not allowed"):
        design_cache.loads(path.read_bytes(), key)
    design, source = _cached()
    assert source == "built" and called == []


def test_the_key_follows_the_source_of_a_plugin_kinds_module(tmp_path, monkeypatch):
    from controllers.registry import ControllerKind, register_controller, unregister_controller

    module = tmp_path / "my_keyed_plugin.py"
    source = ("from controllers.pid import design_pid\n\n\n"
              "def design(plant, **spec):\n    return design_pid(plant, **spec)\n")
    module.write_text(source)
    monkeypatch.syspath_prepend(str(tmp_path))
    import my_keyed_plugin

    register_controller("my_keyed", my_keyed_plugin.design,
                        ControllerKind(fixed={"structure": "pi"}))
    try:
        design_cache.source_digest.cache_clear()
        before = design_cache.design_key(CAN, "my_keyed", 0.01, SPEC, GRID)
        module.write_text(source.replace("**spec)\n", "**spec)  # edited\n"))
        design_cache.source_digest.cache_clear()
        after = design_cache.design_key(CAN, "my_keyed", 0.01, SPEC, GRID)
        assert before != after
        assert design_cache.design_key(CAN, "pid", 0.01, SPEC, GRID) != after
    finally:
        unregister_controller("my_keyed")
        design_cache.source_digest.cache_clear()
