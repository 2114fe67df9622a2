"""The report's inline SVG charts: the curve simplification keeps what a pixel shows."""

from __future__ import annotations

from xml.etree import ElementTree

import numpy as np
import pytest

from scenarios.report.svg import line_chart, nice_ticks, simplify


def farthest_from_polyline(px: np.ndarray, py: np.ndarray, kept: np.ndarray) -> float:
    """Largest distance of an original point to the chord of the kept points around it."""
    worst = 0.0
    for a, b in zip(kept[:-1], kept[1:], strict=True):
        dx, dy = px[b] - px[a], py[b] - py[a]
        d = np.abs(dx * (py[a:b + 1] - py[a]) - dy * (px[a:b + 1] - px[a])) / np.hypot(dx, dy)
        worst = max(worst, float(d.max()))
    return worst


@pytest.mark.parametrize("seed", range(6))
def test_simplified_curve_stays_within_the_tolerance(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(50, 800))
    px = np.linspace(50.0, 628.0, n)
    py = 100.0 + np.cumsum(rng.normal(size=n)) * rng.uniform(0.2, 2.0)
    if seed % 2:  # a held reference: steps with flat stretches
        py = np.round(py / 7.0) * 7.0
    kept = simplify(px, py, 0.35)
    assert kept[0] == 0 and kept[-1] == n - 1 and np.all(np.diff(kept) > 0)
    assert farthest_from_polyline(px, py, kept) <= 0.35 + 1e-9
    assert kept.size < n  # it does drop points


def test_a_straight_line_keeps_its_ends():
    x = np.linspace(0.0, 10.0, 101)
    assert simplify(x, 3.0 * x + 1.0, 0.1).tolist() == [0, 100]
    assert simplify(x[:2], x[:2], 0.1).tolist() == [0, 1]


@pytest.mark.parametrize(("low", "high", "n"), [(0.0, 6.0, 7), (0.0, 2.63, 5), (-0.013, 0.2, 5),
                                                (3.0, 4700.0, 4)])
def test_nice_ticks_are_round_and_inside(low, high, n):
    ticks = nice_ticks(low, high, n)
    assert low - 1e-12 <= ticks[0] and ticks[-1] <= high + 1e-12
    assert 2 <= len(ticks) <= n
    steps = np.diff(ticks)
    assert np.allclose(steps, steps[0])
    mantissa = steps[0] / 10 ** np.floor(np.log10(steps[0]))
    assert round(mantissa, 9) in (1.0, 2.0, 5.0)


def test_nice_ticks_of_an_empty_range():
    assert nice_ticks(1.0, 1.0) == [1.0]
    assert nice_ticks(0.0, 6.0, 7) == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]


def test_chart_is_well_formed_and_breaks_at_missing_values():
    t = np.linspace(0.0, 6.0, 600)
    y = np.sin(t)
    y[200:210] = np.nan
    chart = line_chart(t, [("a <b>", y, "#000000")], x_label="time (s)", y_label="force (N)",
                       label='trace of "x" & y')
    root = ElementTree.fromstring(chart)
    assert root.tag == "svg" and root.get("aria-label") == 'trace of "x" & y'
    curve = root.findall("path")[1].get("d")
    assert curve.count("M") == 2  # two runs around the gap
    assert "a <b>" in "".join(root.itertext())
