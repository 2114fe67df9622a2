"""Inline SVG line charts for the report's force traces, written directly (no matplotlib).

A sweep has one force trace per episode; drawn by matplotlib, they took most of the
report's time (about 0.3 s each) and bytes. Here a chart is a few hundred bytes of markup
per curve: each curve is simplified to the points that move it by more than a third of a
pixel (Ramer-Douglas-Peucker), so a 600-sample trace keeps the points a reader can see.
The page stays script-free; the charts sit inside closed ``<details>`` and the browser
lays them out only when opened.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

#: Default curve colours (matplotlib's C0, C1 and grey, as the other figures).
BLUE, ORANGE, GREY = "#1f77b4", "#ff7f0e", "#808080"


@dataclass(frozen=True)
class ChartSize:
    """The size of a chart in CSS pixels (it scales down with the page).

    Attributes
    ----------
    width_px, height_px : int
        Width and height, CSS pixels.
    """

    width_px: int = 640
    height_px: int = 210


def nice_ticks(low: float, high: float, n: int = 5) -> list[float]:
    """About ``n`` round ticks (steps of 1, 2 or 5 times a power of ten) in ``[low, high]``."""
    if not (math.isfinite(low) and math.isfinite(high)) or high <= low:
        return [low] if math.isfinite(low) else []
    raw = (high - low) / max(n - 1, 1)
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    first = math.ceil(low / step - 1e-9) * step
    count = int(math.floor((high - first) / step + 1e-9)) + 1
    return [round(first + i * step, 12) for i in range(count)]


def simplify(px: np.ndarray, py: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the points of a polyline that keep it within ``tol`` of the original
    (Ramer-Douglas-Peucker; first and last points always kept).

    The segments of one level of the recursion are split together (numpy over all of
    them), so a curve takes about log2(n) passes instead of one Python step per kept point.
    """
    if px.size < 3:
        return np.arange(px.size)
    # first drop the points on a straight line through their neighbours (held references,
    # flat stretches): exact, and it leaves less to the passes below
    cross = np.abs((px[1:-1] - px[:-2]) * (py[2:] - py[:-2])
                   - (py[1:-1] - py[:-2]) * (px[2:] - px[:-2]))
    corners = np.flatnonzero(np.concatenate([[True], cross > 1e-9, [True]]))
    px, py = px[corners], py[corners]
    n = px.size
    keep = np.zeros(n, dtype=bool)
    keep[[0, n - 1]] = True
    points = np.arange(n)
    while True:
        kept = np.flatnonzero(keep)
        inner = points[~keep]
        if inner.size == 0:
            break
        segment = np.searchsorted(kept, inner) - 1  # the kept points on either side
        a, b = kept[segment], kept[segment + 1]
        dx, dy = px[b] - px[a], py[b] - py[a]
        norm = np.hypot(dx, dy)
        rx, ry = px[inner] - px[a], py[inner] - py[a]
        with np.errstate(invalid="ignore", divide="ignore"):
            dist = np.where(norm > 0, np.abs(dx * ry - dy * rx) / norm, np.hypot(rx, ry))
        # the farthest point of each segment (segments are contiguous runs of `inner`)
        order = np.lexsort((-dist, segment))
        first = np.concatenate([[True], segment[order][1:] != segment[order][:-1]])
        farthest = order[first]
        split = farthest[dist[farthest] > tol]
        if split.size == 0:
            break
        keep[inner[split]] = True
    return corners[keep]


def _path(px: np.ndarray, py: np.ndarray, tol: float) -> str:
    """SVG path data of a polyline, broken where a value is not finite."""
    finite = np.isfinite(px) & np.isfinite(py)
    parts = []
    edges = np.flatnonzero(np.diff(np.concatenate([[0], finite.astype(int), [0]])))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        x, y = px[start:stop], py[start:stop]
        points = [f"{x[i]:.1f} {y[i]:.1f}" for i in simplify(x, y, tol)]
        parts.append(f"M{points[0]}" + (f"L{' '.join(points[1:])}" if len(points) > 1
                                         else "h0.1"))  # a lone point: a dot
    return "".join(parts)


def line_chart(x: np.ndarray, series: Sequence[tuple[str, np.ndarray, str]], *,
               x_label: str, y_label: str, size: ChartSize = ChartSize(),
               label: str = "", tol_px: float = 0.35,
               bands: Sequence[tuple[float, float, str, str]] = ()) -> str:
    """An inline ``<svg>`` line chart: axes with round ticks, one path per series, a legend.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Abscissae shared by the series.
    series : sequence of (str, ndarray, str)
        Legend label, ordinates (shape (n,)) and colour of each curve.
    x_label, y_label : str
        Axis labels (with units).
    size : ChartSize
        Width and height in CSS pixels (default 640 x 210).
    label : str
        Accessible name of the chart (``aria-label``).
    tol_px : float
        Simplification tolerance, pixels.
    bands : sequence of (float, float, str, str)
        Shaded spans of the abscissa behind the curves: start, end, a label
        written at the top of the span (empty: none) and a fill colour.

    Returns
    -------
    str
        The ``<svg>`` element (no XML namespace attribute: HTML5 inline SVG).
    """
    width, height = size.width_px, size.height_px
    left, right, top, bottom = 50, 12, 26, 40
    pw, ph = width - left - right, height - top - bottom
    x = np.asarray(x, dtype=float)
    ys = [np.asarray(y, dtype=float) for _, y, _ in series]
    finite_x = x[np.isfinite(x)]
    x0, x1 = (float(finite_x.min()), float(finite_x.max())) if finite_x.size else (0.0, 1.0)
    values = np.concatenate([y[np.isfinite(y)] for y in ys]) if ys else np.zeros(0)
    y0 = min(0.0, float(values.min())) if values.size else 0.0
    y1 = float(values.max()) if values.size else 1.0
    x1 = x1 if x1 > x0 else x0 + 1.0
    y1 = y0 + 1.0 if y1 <= y0 else y1 + 0.05 * (y1 - y0)

    def sx(v: np.ndarray | float) -> np.ndarray | float:
        return left + (np.asarray(v) - x0) / (x1 - x0) * pw

    def sy(v: np.ndarray | float) -> np.ndarray | float:
        return top + ph - (np.asarray(v) - y0) / (y1 - y0) * ph

    out = [f'<svg class="chart" viewBox="0 0 {width} {height}" width="{width}" '
           f'height="{height}" role="img" aria-label="{html.escape(label)}" '
           'font-family="sans-serif" font-size="12">',
           f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" '
           'stroke="#999"/>']
    for b0, b1, text, fill in bands:
        a, b = float(sx(max(b0, x0))), float(sx(min(b1, x1)))
        if b > a:
            out.append(f'<rect x="{a:.1f}" y="{top}" width="{b - a:.1f}" height="{ph}" '
                       f'fill="{fill}"/>')
            if text:
                out.append(f'<text x="{a + 2:.1f}" y="{top + 11}" font-size="10" '
                           f'fill="#555">{html.escape(text)}</text>')
    grid = []
    for t in nice_ticks(y0, y1):
        py = float(sy(t))
        grid.append(f"M{left},{py:.1f}h{pw}")
        out.append(f'<text x="{left - 5}" y="{py + 4:.1f}" text-anchor="end">{t:g}</text>')
    for t in nice_ticks(x0, x1, 7):
        px = float(sx(t))
        grid.append(f"M{px:.1f},{top}v{ph}")
        out.append(f'<text x="{px:.1f}" y="{top + ph + 15}" text-anchor="middle">{t:g}</text>')
    out.append(f'<path d="{"".join(grid)}" stroke="#ddd" stroke-width="0.8" fill="none"/>')
    out.append(f'<text x="{left + pw / 2:.0f}" y="{height - 6}" text-anchor="middle">'
               f"{html.escape(x_label)}</text>")
    out.append(f'<text transform="translate(13 {top + ph / 2:.0f}) rotate(-90)" '
               f'text-anchor="middle">{html.escape(y_label)}</text>')
    px_all = np.asarray(sx(x), dtype=float)
    legend_x = left
    for (name, _, color), y in zip(series, ys, strict=True):
        d = _path(px_all, np.asarray(sy(y), dtype=float), tol_px)
        out.append(f'<path d="{d}" stroke="{color}" stroke-width="1.4" fill="none"/>')
        out.append(f'<path d="M{legend_x},{top - 10}h18" stroke="{color}" stroke-width="2"/>'
                   f'<text x="{legend_x + 22}" y="{top - 6}">{html.escape(name)}</text>')
        legend_x += 30 + 7 * len(name)
    out.append("</svg>")
    return "".join(out)
