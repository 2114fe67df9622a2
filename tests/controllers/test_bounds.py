import pytest

from controllers import SpecificationError, force_bounds, slip_threshold_n


def test_slip_threshold_matches_calibration():
    # CALIBRATION.md: 0.2 kg box, mu = 1, two-sided pinch -> 0.98 N
    assert slip_threshold_n(0.2, 1.0) == pytest.approx(0.2 * 9.81 / 2.0)
    assert slip_threshold_n(0.2, 1.0) == pytest.approx(0.98, abs=0.01)


def test_force_bounds_and_infeasible_object():
    b = force_bounds(0.4, 0.5, fragility_limit_n=30.0, safety_factor=1.5)
    assert b.min_n == pytest.approx(1.5 * 0.4 * 9.81 / 1.0)
    assert b.max_n == 30.0
    with pytest.raises(SpecificationError, match=r"needs at least 5.89 N .* breaks at 4 N"):
        force_bounds(0.4, 0.5, fragility_limit_n=4.0)
