"""Controller design for an object from a scenario's specification."""

from __future__ import annotations

import numpy as np
import pytest

from controllers import SlipReflex
from controllers.errors import SpecificationError
from controllers.design import cached_design_plant, design_for_object
from sim.objects import make_object

CAN = make_object("can", mass_kg=0.4, friction=0.5)


@pytest.mark.parametrize("kind", ["pid", "lead_lag"])
def test_bandwidth_specification_is_met(kind: str) -> None:
    design = design_for_object(CAN, kind, bandwidth_rad_s=80.0)
    assert design.margins.bandwidth_rad_s == pytest.approx(80.0, rel=0.02)
    assert design.margins.phase_margin_deg == pytest.approx(60.0, abs=1.0)


def test_unreachable_bandwidth_names_the_reachable_range() -> None:
    with pytest.raises(SpecificationError, match="reachable"):
        design_for_object(CAN, "pid", bandwidth_rad_s=20.0)


def test_design_plant_is_cached_per_object_and_period() -> None:
    assert cached_design_plant(CAN, 0.01) is cached_design_plant(CAN, 0.01)
    assert cached_design_plant(CAN, 0.01) is not cached_design_plant(CAN, 0.02)


def test_mpc_bounds_follow_the_object_and_reflex_wraps() -> None:
    egg_like = CAN.replace(break_force_n=12.0)
    design = design_for_object(egg_like, "mpc", safety_factor=2.0,
                               slip_reflex={"latency_s": 0.05, "gain": 0.3})
    assert design.spec["force_min_n"] == pytest.approx(2.0 * 0.4 * 9.81 / (2 * 0.5))
    assert design.spec["force_max_n"] == 12.0
    assert isinstance(design.controller, SlipReflex)
    assert design.controller.max_reference_n == 12.0


def test_unknown_controller_lists_valid_names() -> None:
    with pytest.raises(LookupError, match="lead_lag"):
        design_for_object(CAN, "fuzzy")


def test_design_meeting_the_margin_but_unstable_is_refused() -> None:
    # on the held block the lead's high-frequency gain lifts |L| above 1 where the
    # phase crosses -180 deg: the phase margin is met at 100 rad/s, the loop is unstable
    block = make_object("block", mass_kg=0.3)
    with pytest.raises(SpecificationError, match=r"unstable closed loop \(gain margin -"):
        design_for_object(block, "lead_lag", phase_margin_deg=60.0, crossover_rad_s=100.0)
    assert design_for_object(block, "lead_lag", phase_margin_deg=60.0,
                             crossover_rad_s=60.0).margins.stable


def test_operating_force_sets_the_linearization_point() -> None:
    soft = cached_design_plant(CAN, 0.01, 5.0)  # on the pads' springs
    stiff = cached_design_plant(CAN, 0.01, None)  # default: 10 N, pads bottomed out
    assert soft.y0_n == pytest.approx(5.0, rel=0.05)
    assert stiff.y0_n == pytest.approx(10.0, rel=0.05)
    w = 30.0  # the compliant pads make the plant several times slower below ~8 N per side
    z = np.exp(1j * w * 0.01)
    assert abs(stiff.model(z)) > 2.0 * abs(soft.model(z))
