"""Object graphs as JSON and arrays: what goes in comes out, and nothing else is ever built."""

from __future__ import annotations

import collections
import json
import math

import control
import numpy as np
import pytest

from controllers.approach import ContactGate
from controllers.base import Implementation
from controllers.pid import PID
from sim.codec import CodecError, StoredSystem, decode, encode, state_space_matrices
from sim.hand.objects import make_object


def _round_trip(value, **options):
    tree, arrays = encode(value, **options)
    text = json.dumps(tree)  # the tree is plain JSON
    return decode(json.loads(text), [a.copy() for a in arrays], **options)


def test_values_containers_and_shared_references_come_back():
    shared = [1, 2]
    value = {"a": shared, "b": shared, 1.5: (np.float32(2.5), np.int64(3)),
             "inf": math.inf, "nan": math.nan, "set": {1, 2}, "frozen": frozenset({"x"}),
             "queue": collections.deque([1.0, 2.0], maxlen=3), "none": None, "flag": True,
             "array": np.arange(6, dtype=np.int16).reshape(2, 3)}
    value["self"] = value  # a cycle
    out = _round_trip(value)
    assert out["a"] is out["b"] and out["a"] == [1, 2]
    assert out["self"] is out
    assert out[1.5] == (np.float32(2.5), np.int64(3))
    assert type(out[1.5][0]) is np.float32 and type(out[1.5][1]) is np.int64
    assert out["inf"] == math.inf and math.isnan(out["nan"])
    assert out["set"] == {1, 2} and out["frozen"] == frozenset({"x"})
    assert out["queue"] == collections.deque([1.0, 2.0]) and out["queue"].maxlen == 3
    assert out["array"].dtype == np.int16 and out["array"].tolist() == [[0, 1, 2], [3, 4, 5]]


def test_control_systems_come_back_as_the_same_matrices():
    ss = control.ss([[0.9, 0.1], [0.0, 0.8]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]], 0.01)
    tf = control.tf([0.5, 0.1], [1.0, -0.7], 0.01)
    ss2, tf2 = _round_trip((ss, tf))
    for name in "ABCD":
        np.testing.assert_array_equal(getattr(ss2, name), getattr(ss, name))
    assert ss2.dt == 0.01 and tf2.dt == 0.01
    np.testing.assert_array_equal(tf2.num[0][0], tf.num[0][0])
    np.testing.assert_array_equal(tf2.den[0][0], tf.den[0][0])


def _analysis(plant, controller):
    from controllers.design import OperatingAnalysis

    return OperatingAnalysis(force_n=5.0, margins=None, plant=plant, controller=controller,
                             how="linearized")


def test_a_marked_attribute_keeps_its_system_as_matrices_until_it_is_read():
    ss = control.ss([[0.9, 0.1], [0.0, 0.8]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]], 0.01,
                    inputs=["u"], outputs=["y"])
    tf = control.tf([0.5, 0.1], [1.0, -0.7], 0.01)
    out = _round_trip(_analysis(ss, tf))
    assert isinstance(out.__dict__["plant"], StoredSystem)  # nothing built yet
    assert isinstance(out.__dict__["controller"], StoredSystem)
    for got, want in zip(state_space_matrices(out, "plant"), (ss.A, ss.B, ss.C, ss.D),
                         strict=True):
        np.testing.assert_array_equal(got, want)
    assert isinstance(out.__dict__["plant"], StoredSystem)  # the matrices built nothing
    again = _round_trip(out)  # stored again without being built
    assert isinstance(again.__dict__["plant"], StoredSystem)
    for result in (out, again):
        plant = result.plant  # first read: a python-control system, kept
        assert isinstance(plant, control.StateSpace) and result.plant is plant
        for name in "ABCD":
            np.testing.assert_array_equal(getattr(plant, name), getattr(ss, name))
        assert plant.dt == 0.01 and plant.input_labels == ["u"] and plant.output_labels == ["y"]
        assert isinstance(result.controller, control.TransferFunction)
        np.testing.assert_array_equal(result.controller.den[0][0], tf.den[0][0])
    fresh = _analysis(ss, None)  # constructed: the system as given, nothing stored
    assert fresh.plant is ss and fresh.controller is None


def test_a_stored_system_with_shapes_that_do_not_agree_is_refused():
    tree, arrays = encode(_analysis(control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], 0.01), None))
    arrays = [np.zeros((2, 2)) if a.shape == (1, 1) and i == 0 else a
              for i, a in enumerate(arrays)]
    with pytest.raises(CodecError, match="state-space shapes"):
        decode(tree, arrays)


def test_griploop_objects_and_their_bound_methods_come_back_working():
    pid = PID(kp=0.02, ki_per_s=0.5, kd_s=0.0, derivative_filter_s=0.02,
              implementation=Implementation(dt_s=0.01))
    gate = ContactGate(pid, closing_command=0.2, feedforward=pid.act, dt_s=0.01)
    gate2 = _round_trip(gate)
    assert type(gate2) is ContactGate and gate2.controller is not pid
    assert gate2.feedforward.__self__ is gate2.controller  # the shared object, once
    obs = {"time_s": 0.0, "reference_n": 5.0, "grip_force_n": 1.0}
    pid.reset()
    gate2.controller.reset()
    assert gate2.controller.act(obs) == pid.act(obs)
    assert _round_trip(make_object("egg")) == make_object("egg")


@pytest.mark.parametrize("value, what", [
    (lambda x: x, "function"),
    (np.array([object()]), "object array"),
    (__import__("fractions").Fraction(1, 3), "fractions.Fraction"),
    (PID, "type"),
])
def test_what_is_not_data_of_griploop_is_refused(value, what):
    with pytest.raises(CodecError, match="cannot store|object array"):
        encode({"x": value})


@pytest.mark.parametrize("tree, message", [
    ({"$object": "os:system", "id": 0, "state": {}}, "not allowed"),
    ({"$object": "subprocess:Popen", "id": 0, "state": {}}, "not allowed"),
    ({"$object": "controllers.pid:design_pid", "id": 0, "state": {}}, "is not a class"),
    ({"$object": "controllers.pid:np.ndarray", "id": 0, "state": {}}, "is not a class"),
    ({"$method": {"$object": "controllers.pid:PID", "id": 0, "state": {}}, "name": "__init__",
      "id": 1}, None),
    ({"$method": {"$object": "controllers.pid:PID", "id": 0, "state": {}},
      "name": "__class__", "id": 1}, "has no method"),
    ({"$array": 3}, "array 3"),
    ({"$ref": 7}, "reference 7"),
    ({"$eval": "1"}, "unknown tag"),
    ([1, 2], "bare list"),
])
def test_a_foreign_tree_builds_nothing_it_does_not_allow(tree, message):
    if message is None:  # a real method of an allowed class: allowed, and only bound
        method = decode(tree, [])
        assert method.__func__ is PID.__init__
        return
    with pytest.raises(CodecError, match=message):
        decode(tree, [np.zeros(1)])


def test_a_plugin_class_needs_its_module_named(tmp_path, monkeypatch):
    (tmp_path / "my_codec_plugin.py").write_text("class Gain:\n    pass\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    import my_codec_plugin

    gain = my_codec_plugin.Gain()
    gain.k = 2.0
    with pytest.raises(CodecError, match="cannot store a my_codec_plugin.Gain"):
        encode(gain)
    out = _round_trip(gain, modules=("my_codec_plugin",))
    assert type(out) is my_codec_plugin.Gain and out.k == 2.0
    tree, arrays = encode(gain, modules=("my_codec_plugin",))
    with pytest.raises(CodecError, match="not allowed"):
        decode(tree, arrays)  # not named by the reader: not built
