"""The hand's rest threshold: set from sustained rest, closed by contracting, opened by relaxing."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.rest_gate import MIN_REST_WINDOWS, RestGate, rest_thresholds

DT = 0.125


def _session(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Alternating 4 s of rest and 4 s of squeeze, the estimate noisy around the force."""
    force = np.tile(np.r_[np.zeros(32), np.full(32, 20.0)], 4)
    estimate = force + rng.normal(0.0, 1.0, force.size)
    return estimate, force


def test_thresholds_come_from_sustained_rest_only() -> None:
    estimate, force = _session(np.random.default_rng(0))
    on, off = rest_thresholds(estimate, force, DT)
    low = force < 1.0
    away = np.convolve(low, np.ones(9), mode="same") == 9  # 0.5 s of rest on either side
    rest = estimate[away]
    assert on == pytest.approx(np.percentile(rest, 95))
    assert off == pytest.approx(max(np.percentile(rest, 50), 0.0))
    # the windows next to a squeeze are not rest: a lag between estimate and force
    # there must not raise the threshold
    lagged = np.roll(estimate, 3)
    assert rest_thresholds(lagged, force, DT)[0] < 3.0


def test_no_threshold_without_enough_rest_or_force() -> None:
    assert rest_thresholds(np.ones(50), np.full(50, 5.0), DT) == (0.0, 0.0)
    assert rest_thresholds(np.ones(50), np.zeros(50), DT) == (0.0, 0.0)
    short = np.r_[np.zeros(MIN_REST_WINDOWS - 1 + 8), np.full(40, 20.0)]
    assert rest_thresholds(short + 0.5, short, DT) == (0.0, 0.0)


def test_the_gate_closes_above_on_and_opens_below_off() -> None:
    gate = RestGate(on_n=2.0, off_n=0.5)
    out = [gate.step(v) for v in (1.5, 2.5, 1.0, 0.6, 0.4, 1.9, 2.0)]
    assert out == [0.0, 2.5, 1.0, 0.6, 0.0, 0.0, 2.0]
    gate.reset()
    assert not gate.closed and gate.step(1.0) == 0.0
    assert list(RestGate().run([0.3, -0.1, 5.0])) == [0.3, -0.1, 5.0]  # no threshold
    constant = RestGate(on_n=3.0, off_n=3.0)  # an estimate that never changes passes
    assert list(constant.run([3.0, 3.0])) == [3.0, 3.0]
