"""check_scenario_kind: the shipped kinds pass, and each fault is one line naming its check."""

from __future__ import annotations

import pytest

from scenarios.runners.dispatch import (
    RunnerUnavailableError,
    register_kind,
    scenario_kinds,
    unregister_kind,
)
from scenarios.runners.kind_checks import check_scenario_kind


def run_toy(scenario) -> dict:
    """A runner of one scenario."""
    return {"mass_kg": scenario.object.mass_kg}


def run_two(scenario, extra) -> dict:
    """Not a runner: it needs a second argument."""
    return {}


TOYS = {
    "toy_kind_ok": (run_toy, ("grasp_lift_hold",)),
    "toy_kind_any": (run_toy, ()),
    "toy_kind_unknown_protocol": (run_toy, ("juggling",)),
    "toy_kind_two_arguments": (run_two, ()),
    "toy_kind_missing_module": ("no_such_module_here:run", ()),
}


@pytest.fixture
def toys():
    for name, (runner, protocols) in TOYS.items():
        register_kind(name, runner, protocols=protocols)
    yield
    for name in TOYS:
        unregister_kind(name)


@pytest.mark.parametrize("name", scenario_kinds())
def test_the_shipped_kinds_pass(name):
    assert [f.line() for f in check_scenario_kind(name)] == []


@pytest.mark.parametrize("name", ["toy_kind_ok", "toy_kind_any"])
def test_good_toys_pass(toys, name):
    assert check_scenario_kind(name) == []


@pytest.mark.parametrize("name, check, found", [
    ("toy_kind_unknown_protocol", "schema", "juggling"),
    ("toy_kind_two_arguments", "runner_signature", "extra"),
    ("toy_kind_missing_module", "runner", "no_such_module_here"),
])
def test_each_fault_is_one_line_naming_its_check(toys, name, check, found):
    failures = check_scenario_kind(name)
    assert [f.check for f in failures] == [check], [f.line() for f in failures]
    line = failures[0].line()
    assert line.startswith(f"scenario kind {name}: {check}: expected ") and found in line
    assert "\n" not in line


def test_an_unknown_name_is_refused():
    with pytest.raises(RunnerUnavailableError):
        check_scenario_kind("no_such_kind")
