"""check_controller: the shipped kinds pass, and each fault is one line naming its check."""

from __future__ import annotations

from types import SimpleNamespace

import control
import numpy as np
import pytest

from controllers.analysis import loop_margins
from controllers.checks import (
    MARGIN_TOLERANCE_DEG,
    check_controller,
    reference_plant,
    standard_observations,
)
from controllers.errors import UnknownControllerError
from controllers.registry import controller_names, register_controller, unregister_controller


class Integral:
    """``u += ki T e``, clipped to -1..1, plus ``bias`` (a fault: 0 is right)."""

    def __init__(self, ki_per_s: float, period_s: float, *, bias: float = 0.0,
                 report=None) -> None:
        self.ki_per_s, self.period_s, self.bias, self.u = ki_per_s, period_s, bias, 0.0
        if report is not None:
            self.report_ = report

    def reset(self, u0: float = 0.0) -> None:
        self.u = float(u0)

    def act(self, observation) -> float:
        step = self.ki_per_s * self.period_s * (observation.reference_n - observation.grip_force_n)
        self.u = float(np.clip(self.u + step, -1.0, 1.0))
        return self.u + self.bias

    def loop(self, plant):
        return control.tf([self.ki_per_s * self.period_s], [1.0, -1.0], self.period_s) * plant


def _ki_for_crossover(plant, wc_rad_s: float) -> float:
    """The integral gain whose loop on ``plant`` crosses over at ``wc_rad_s``."""
    z = np.exp(1j * wc_rad_s * plant.dt)
    return 1.0 / abs(complex(control.evalfr(plant, z)) * plant.dt / (z - 1.0))


def _margins(ki_per_s: float):
    plant = reference_plant()
    return loop_margins(Integral(ki_per_s, plant.dt).loop(plant))


GOOD_KI = _ki_for_crossover(reference_plant(), 5.0)  # a slow, well-damped integral loop


def _designs() -> dict:
    """``name -> design`` of the toy kinds, one fault each."""
    claim = _margins(GOOD_KI).phase_margin_deg + 10.0  # more than the loop has
    lying = SimpleNamespace(spec={}, margins=SimpleNamespace(phase_margin_deg=claim,
                                                             gain_margin_db=60.0))
    return {
        "toy_good": lambda plant, **spec: Integral(GOOD_KI, plant.dt),
        "toy_overrange": lambda plant, **spec: Integral(GOOD_KI, plant.dt, bias=1.5),
        "toy_unstable": lambda plant, **spec: Integral(1e3 * GOOD_KI, plant.dt),
        "toy_overclaim": lambda plant, **spec: Integral(
            GOOD_KI, plant.dt, report=SimpleNamespace(spec={"phase_margin_deg": claim})),
        "toy_lying_report": lambda plant, **spec: Integral(GOOD_KI, plant.dt, report=lying),
        "toy_failing_design": lambda plant, **spec: 1 / 0,
    }


@pytest.fixture
def toys():
    for name, design in _designs().items():
        register_controller(name, design)
    yield
    for name in _designs():
        unregister_controller(name)


def test_the_reference_plant_and_observations_are_standard():
    a, b = standard_observations(), standard_observations()
    assert a == b and len(a) > 100
    assert all(np.isfinite([o.reference_n, o.grip_force_n]).all() for o in a)
    assert any(o.slip_detected for o in a) and any(o.both_sides for o in a)
    assert reference_plant().dt == a[1].time_s - a[0].time_s


@pytest.mark.parametrize("name", controller_names())
def test_the_shipped_controllers_pass(name):
    assert [f.line() for f in check_controller(name)] == []


def test_a_good_toy_passes(toys):
    assert check_controller("toy_good") == []


@pytest.mark.parametrize("name, check", [
    ("toy_overrange", "command_range"),
    ("toy_unstable", "closed_loop_stable"),
    ("toy_overclaim", "stated_phase_margin"),
    ("toy_failing_design", "design"),
])
def test_each_fault_is_one_line_naming_its_check(toys, name, check):
    failures = check_controller(name)
    assert [f.check for f in failures] == [check], [f.line() for f in failures]
    line = failures[0].line()
    assert line.startswith(f"controller {name}: {check}: expected ") and "\n" not in line


def test_a_report_whose_margins_the_loop_does_not_have_is_found(toys):
    failures = check_controller("toy_lying_report")
    assert {f.check for f in failures} == {"report_margins"}
    said = [f for f in failures if "phase_margin_deg" in f.expected]
    assert len(said) == 1 and f"within {MARGIN_TOLERANCE_DEG:g}" in said[0].expected


def test_an_unknown_name_is_refused():
    with pytest.raises(UnknownControllerError):
        check_controller("no_such_controller")
