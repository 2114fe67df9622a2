"""Controller designs over an object's force range and their analysis at any force."""

from __future__ import annotations

import numpy as np
import pytest

from controllers import DesignSpec, ReflexSpec, SlipReflex
from controllers.design import (
    cached_design_plant,
    cached_plant_family,
    design_for_object,
    worst_case,
)
from controllers.errors import SpecificationError
from controllers.schedule import ScheduledController
from sim.hand.objects import make_object

CAN = make_object("can", mass_kg=0.4, friction=0.5)


@pytest.mark.parametrize("kind", ["pid", "lead_lag"])
def test_bandwidth_specification_is_met_at_each_design_force(kind: str) -> None:
    # each design force searches its own crossover: two forces of the default grid, one
    # on the soft pads and one bottomed out, test what the twenty would (at a tenth of
    # the cost)
    forces = (5.0, 15.0)
    design = design_for_object(CAN, kind, DesignSpec(bandwidth_rad_s=80.0, forces_n=forces))
    assert design.design_forces_n == list(forces)
    for force in forces:
        m = design.analyse(force).margins
        assert m.bandwidth_rad_s == pytest.approx(80.0, rel=0.02)
        assert m.phase_margin_deg == pytest.approx(60.0, abs=1.0)


def test_unreachable_bandwidth_names_the_reachable_range() -> None:
    with pytest.raises(SpecificationError, match="reachable"):
        design_for_object(CAN, "pid", DesignSpec(bandwidth_rad_s=2000.0))


def test_design_plant_is_cached_per_object_and_period() -> None:
    assert cached_design_plant(CAN, 0.01) is cached_design_plant(CAN, 0.01)
    assert cached_design_plant(CAN, 0.01) is not cached_design_plant(CAN, 0.02)
    assert cached_plant_family(CAN, 0.01) is cached_plant_family(CAN, 0.01)


def test_mpc_bound_is_sensed_and_the_reflex_stops_below_the_user_limit() -> None:
    design = design_for_object(CAN, "mpc", DesignSpec(
        safety_factor=2.0, force_max_n=12.0, slip_reflex=ReflexSpec(latency_s=0.05, gain=0.3)))
    assert design.spec["slip_bound"].startswith("sensed")
    assert design.spec["force_max_n"] == 12.0
    mpc = design.core.designs[0]
    assert mpc.force_bounds is None  # nothing from the object's true mass or friction
    assert mpc.slip_sensing.safety_factor == 2.0
    assert isinstance(design.controller, SlipReflex)
    assert design.controller.ceiling_n == pytest.approx(0.8 * 12.0)


def test_unknown_controller_lists_valid_names() -> None:
    with pytest.raises(LookupError, match="lead_lag"):
        design_for_object(CAN, "fuzzy")


def test_design_meeting_the_margin_but_unstable_is_refused_at_that_force() -> None:
    # on the held block the lead's high-frequency gain lifts |L| above 1 where the
    # phase crosses -180 deg: the phase margin is met at 100 rad/s, the loop is unstable
    block = make_object("block", mass_kg=0.3)
    with pytest.raises(SpecificationError, match=r"unstable closed loop \(gain margin -"):
            design_for_object(block, "lead_lag", DesignSpec(phase_margin_deg=60.0,
                                                        crossover_rad_s=100.0))
    ok = design_for_object(block, "lead_lag", DesignSpec(phase_margin_deg=60.0,
                                                         crossover_rad_s=60.0))
    assert not ok.notes and all(a.margins.stable for a in ok.analyse_grid() if a.ok)


def test_operating_force_sets_the_linearization_point() -> None:
    soft = cached_design_plant(CAN, 0.01, 5.0)  # on the pads' springs
    stiff = cached_design_plant(CAN, 0.01, None)  # default: 10 N, pads bottomed out
    assert soft.y0_n == pytest.approx(5.0, rel=0.05)
    assert stiff.y0_n == pytest.approx(10.0, rel=0.05)
    w = 30.0  # the compliant pads make the plant several times slower below ~8 N per side
    z = np.exp(1j * w * 0.01)
    assert abs(stiff.model(z)) > 2.0 * abs(soft.model(z))


@pytest.mark.parametrize("kind", ["pid", "lead_lag", "mpc"])
def test_default_designs_keep_45_deg_over_the_whole_range(kind: str) -> None:
    can = make_object("can", mass_kg=0.2, friction=1.0)
    design = design_for_object(can, kind)
    analyses = design.analyse_grid()
    worst = worst_case(analyses)
    assert worst["n_points"] >= len(analyses) - 1
    assert worst["all_stable"]
    assert worst["phase_margin_deg"] >= 45.0


def test_a_fixed_design_is_analysed_honestly_away_from_its_force() -> None:
    can = make_object("can", mass_kg=0.2, friction=1.0)
    fixed = design_for_object(can, "pid", DesignSpec(scheduled=False, operating_force_n=10.0))
    scheduled = design_for_object(can, "pid")
    assert fixed.design_forces_n == [10.0]
    # at its design force the fixed PI meets the specification ...
    assert fixed.analyse(10.0).margins.phase_margin_deg == pytest.approx(60.0, abs=0.5)
    # ... on the soft pads it loses most of its phase margin, while the scheduled one keeps it
    soft_fixed = fixed.analyse(4.0).margins
    soft_sched = scheduled.analyse(4.0).margins
    assert soft_fixed.crossover_rad_s[0] < 20.0
    assert soft_sched.phase_margin_deg == pytest.approx(60.0, abs=1.0)


def test_analysis_outside_the_range_names_the_range() -> None:
    design = design_for_object(CAN, "pid")
    with pytest.raises(ValueError, match=r"1\.\.36 N"):
        design.check_force(50.0)


def test_the_operating_point_contract() -> None:
    design = design_for_object(CAN, "pid")
    entry = design.analyse(5.0).to_dict()
    assert set(entry) >= {"force_n", "margins", "plant", "controller", "loop"}
    assert set(entry["margins"]) >= {"gain_margin_db", "phase_margin_deg", "delay_margin_s",
                                     "crossover_rad_s", "ms", "stable"}
    for key in ("plant", "controller", "loop"):
        assert set(entry[key]) == {"A", "B", "C", "D", "dt"}
        assert entry[key]["dt"] == 0.01
    # the loop is the controller (error -> applied command, delay included) times the plant
    import control

    def ss(d):
        return control.ss(np.array(d["A"]), np.array(d["B"]), np.array(d["C"]),
                          np.array(d["D"]), d["dt"])

    z = np.exp(1j * np.array([3.0, 30.0]) * 0.01)
    lhs = ss(entry["loop"])(z)
    rhs = ss(entry["controller"])(z) * ss(entry["plant"])(z)
    assert np.allclose(lhs, rhs, rtol=1e-6)
    assert isinstance(design.core, ScheduledController)
