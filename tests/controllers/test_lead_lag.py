import control
import numpy as np
import pytest

from controllers import (
    Implementation,
    LinearController,
    SpecificationError,
    design_lead_lag,
    sweep_margins,
)

DT_S = 0.01  # control period of the conftest plant


@pytest.mark.parametrize(("pm", "wc"), [(50.0, 30.0), (55.0, 40.0), (60.0, 20.0)])
def test_design_meets_spec(plant, pm, wc):
    ctl = design_lead_lag(plant, phase_margin_deg=pm, crossover_rad_s=wc)
    m = ctl.report_.margins
    assert m.stable
    assert m.crossover_rad_s == pytest.approx([wc], rel=0.02)
    assert m.phase_margin_deg == pytest.approx(pm, abs=1.0)
    sw = sweep_margins(ctl.loop(plant))
    assert sw.crossover_rad_s == pytest.approx(m.crossover_rad_s, rel=1e-4)
    assert sw.phase_margins_deg == pytest.approx(m.phase_margins_deg, abs=0.01)
    assert sw.gain_margins_db == pytest.approx(m.gain_margins_db, abs=0.01)


def test_lead_stage_is_the_textbook_one(plant):
    ctl = design_lead_lag(plant, phase_margin_deg=55.0, crossover_rad_s=40.0)
    p = ctl.report_.parameters
    wz, wp = p["zero_rad_s"], p["pole_rad_s"]
    # maximum lead of (1 + s/wz)/(1 + s/wp) sits at sqrt(wz wp) with sin(phi) = (b-1)/(b+1)
    assert np.sqrt(wz * wp) == pytest.approx(40.0)
    beta = wp / wz
    assert np.rad2deg(np.arcsin((beta - 1) / (beta + 1))) == pytest.approx(
        p["lead_per_stage_deg"])


def test_unreachable_lead_names_the_limit(plant):
    with pytest.raises(SpecificationError,
                       match=r"needs 8\d\.\d deg of lead; a single lead stage gives at most 65"):
        design_lead_lag(plant, phase_margin_deg=80.0, crossover_rad_s=60.0)
    two = design_lead_lag(plant, phase_margin_deg=80.0, crossover_rad_s=60.0, n_lead_stages=2)
    assert two.report_.margins.phase_margin_deg == pytest.approx(80.0, abs=1.0)


def test_unsaturated_law_equals_transfer_function(plant):
    ctl = design_lead_lag(plant, phase_margin_deg=55.0, crossover_rad_s=40.0,
                          implementation=Implementation(u_limits=(-1e9, 1e9)))
    rng = np.random.default_rng(3)
    e = rng.normal(0.0, 2.0, 80)
    u_law = np.array([ctl.step(ek, 0.0) for ek in e])
    t = np.arange(e.size) * DT_S
    u_tf = control.forced_response(ctl.transfer_function(), T=t, U=e).outputs
    assert u_law == pytest.approx(np.asarray(u_tf).ravel(), abs=1e-9)


def test_conditioning_anti_windup_tracks_the_applied_command(plant):
    ctl = design_lead_lag(plant, phase_margin_deg=55.0, crossover_rad_s=40.0,
                          implementation=Implementation(u_limits=(-0.1, 0.1)))
    for _ in range(300):
        u = ctl.step(50.0, 0.0)  # unreachable: saturated throughout
    assert u == 0.1
    # back at zero error the output leaves the limit at once: no wound-up state
    assert abs(ctl.step(0.0, 0.0)) < 0.1


def test_linear_controller_rejects_strictly_proper():
    with pytest.raises(ValueError, match="biproper"):
        LinearController(control.tf([1.0], [1.0, -0.5], DT_S))
