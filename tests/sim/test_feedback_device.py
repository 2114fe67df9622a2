"""The feedback stimulator's output (what ``griploop live --feedback`` publishes)."""

from __future__ import annotations

import pytest

from sim.user.feedback import FeedbackDevice
from sim.user.operator import OperatorParams


def test_force_vibration_codes_the_grip_level_and_is_silent_without_contact():
    dev = FeedbackDevice("force_vibration", force_range_n=30.0)
    n = OperatorParams().vibration_levels
    assert dev.output(0.0, 0.2, 0.0) == 0.0  # no contact
    assert dev.output(0.0, 30.0, 0.0) == 1.0 and dev.output(0.0, 99.0, 0.0) == 1.0
    level = round(n * 12.0 / 30.0)  # nearest level
    assert dev.output(0.0, 12.0, 0.0) == pytest.approx(level / (n - 1))


def test_slip_vibration_bursts_once_per_slip_and_rearms():
    p = OperatorParams()
    dev = FeedbackDevice("slip_vibration", force_range_n=30.0, params=p)
    fast, slow = 2 * p.slip_sensor_m_s, 0.1 * p.slip_sensor_m_s
    assert dev.output(0.0, 5.0, slow) == 0.0
    assert dev.output(0.01, 5.0, fast) == 1.0  # onset
    assert dev.output(0.01 + p.slip_burst_s / 2, 5.0, fast) == 1.0
    assert dev.output(0.02 + p.slip_burst_s, 5.0, fast) == 0.0  # one burst per slip
    assert dev.output(0.03 + p.slip_burst_s, 5.0, slow) == 0.0  # re-armed
    t = 0.04 + p.slip_burst_s
    assert dev.output(t, 5.0, fast) == 1.0  # the next slip


def test_no_feedback_and_bad_mode():
    assert FeedbackDevice("none", force_range_n=30.0).output(0.0, 10.0, 1.0) == 0.0
    with pytest.raises(ValueError, match="force_vibration, slip_vibration"):
        FeedbackDevice("buzz", force_range_n=30.0)
