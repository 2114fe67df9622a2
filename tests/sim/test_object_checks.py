"""check_object: the shipped objects pass, and each fault is one line naming its check."""

from __future__ import annotations

import itertools

import pytest

from sim.hand.checks import check_object
from sim.hand.objects import (
    ObjectSpec,
    ObjectSpecError,
    object_names,
    register_object,
    unregister_object,
)

_sizes = itertools.count()


def _growing() -> ObjectSpec:
    """A different radius at every call."""
    return ObjectSpec("toy_growing", "sphere", (0.02 + 0.001 * next(_sizes),), 0.1)


TOYS = {
    "toy_jar": lambda: ObjectSpec("toy_jar", "cylinder", (0.035, 0.06), 0.25, friction=0.6),
    "toy_misnamed": lambda: ObjectSpec("jar", "cylinder", (0.035, 0.06), 0.25),
    "toy_growing": _growing,
    "toy_failing": lambda: ObjectSpec("toy_failing", "sphere", (0.03,), 5.0),  # too heavy
    "toy_not_a_spec": lambda: {"name": "toy_not_a_spec"},
    # a contact too soft to carry its own weight (impedance 0.01..0.02): it sinks through
    "toy_sinking": lambda: ObjectSpec("toy_sinking", "sphere", (0.03,), 0.05,
                                      solref=(0.2, 1.0), solimp=(0.01, 0.02, 0.05)),
}


@pytest.fixture
def toys():
    for name, factory in TOYS.items():
        register_object(name, factory)
    yield
    for name in TOYS:
        unregister_object(name)


@pytest.mark.parametrize("name", object_names())
def test_the_shipped_objects_pass(name):
    assert [f.line() for f in check_object(name)] == []


def test_a_good_toy_passes(toys):
    assert check_object("toy_jar") == []


@pytest.mark.parametrize("name, check, found", [
    ("toy_misnamed", "name", "'jar'"),
    ("toy_growing", "repeatable", "ObjectSpec"),
    ("toy_failing", "spec", "mass_kg"),
    ("toy_not_a_spec", "spec", "dict"),
    ("toy_sinking", "rests", "height -"),
])
def test_each_fault_is_one_line_naming_its_check(toys, name, check, found):
    failures = check_object(name)
    assert [f.check for f in failures] == [check], [f.line() for f in failures]
    line = failures[0].line()
    assert line.startswith(f"object {name}: {check}: expected ") and found in failures[0].found
    assert "\n" not in line


def test_an_unknown_name_is_refused():
    with pytest.raises(ObjectSpecError):
        check_object("no_such_object")
