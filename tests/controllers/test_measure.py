"""The loop measured on the nonlinear MuJoCo hand agrees with the analysis at the held force.

For pid, lead_lag and mpc holding a 0.2 kg can (friction 1.0) in the air at 3, 5,
10 and 20 N, a sine injected at the plant input gives a loop gain within 2 dB of 0 dB
at the predicted crossover and a phase margin within 6 deg of the predicted one.
"""

import numpy as np
import pytest

from controllers.design import design_for_object
from controllers.design_spec import DesignSpec
from controllers.measure import measure_loop, phasor
from sim.hand.objects import make_object

CAN = make_object("can", mass_kg=0.2, friction=1.0)
FORCES_N = (3.0, 5.0, 10.0, 20.0)


@pytest.fixture(scope="module", params=["pid", "lead_lag", "mpc"])
def design(request):
    return design_for_object(CAN, request.param)


def test_phasor_recovers_a_known_sine_on_a_trend():
    t = np.arange(0, 2.0, 0.01)
    x = 3.0 + 0.4 * t + 0.7 * np.cos(9.0 * t - 0.3)
    assert phasor(t, x, 9.0) == pytest.approx(0.7 * np.exp(-0.3j), abs=1e-9)


@pytest.mark.parametrize("force_n", FORCES_N)
def test_measured_loop_matches_the_prediction(design, force_n):
    wc = design.analyse(force_n).margins.crossover_rad_s[0]
    m = measure_loop(design, force_n, frequencies_rad_s=np.array([0.8, 1.0, 1.25]) * wc)
    assert not m.reason
    assert m.held_force_n == pytest.approx(force_n, rel=0.03)
    assert abs(m.gain_at_predicted_crossover_db) <= 2.0
    assert m.phase_margin_deg == pytest.approx(m.predicted_phase_margin_deg, abs=6.0)
    # the sensitivity measured is the one predicted, |S| = 1 / |1 + L|
    for p in m.points:
        assert abs(p.sensitivity) == pytest.approx(abs(1.0 / (1.0 + p.predicted_loop)), rel=0.15)


def test_a_fixed_design_measured_on_the_soft_pads_shows_what_its_analysis_says():
    fixed = design_for_object(CAN, "pid", DesignSpec(scheduled=False, operating_force_n=10.0))
    predicted = fixed.analyse(4.0).margins
    m = measure_loop(fixed, 4.0)
    assert not m.reason
    # designed for 30 rad/s at 10 N; on the soft pads the loop crosses over far lower,
    # and the measurement on the hand agrees with the analysis at 4 N, not with the design
    assert m.crossover_rad_s == pytest.approx(predicted.crossover_rad_s[0], rel=0.15)
    assert m.crossover_rad_s < 20.0
